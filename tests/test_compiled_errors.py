"""Exceptions inside compiled conflict detection arrive as themselves, not as Numba's opaque SystemError.

The scenario fuzzer's ``MCRE 100000`` line ended with ``SystemError: CPUDispatcher(<function detect_all>)
returned a result with an exception set``. The cause was not memory: the harness ends a line that runs
past 20 s with a ``SIGALRM`` handler that raises, and a signal that comes during a long compiled call
is handled at the first Python code after it, which for ``detect_all`` is inside the wrapper that
turns its 20 result arrays into Python objects (Numba's ``_numba_unpickle``); the wrapper does not
check for the error and CPython reports a SystemError. Ctrl-C in a Python session (KeyboardInterrupt)
did the same. A MemoryError in the detection pass ended the run.
"""

from __future__ import annotations

import json
import os
import random
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from aamsim import Simulation
from aamsim.compiled_errors import original_error

ROOT = Path(__file__).resolve().parents[1]


class Interrupted(Exception):
    """What the alarm raises (as the fuzz harness's LineTimeout, or KeyboardInterrupt on Ctrl-C)."""


def _interrupt(signum: int, frame: object) -> None:
    raise Interrupted()


def test_the_original_error_is_the_first_cause_that_is_not_a_system_error() -> None:
    root = Interrupted()
    inner = SystemError("inner")
    inner.__cause__ = root
    outer = SystemError("outer")
    outer.__cause__ = inner
    assert original_error(outer) is root
    assert original_error(SystemError("alone")) is None
    handled = SystemError("raised while another was handled")
    handled.__context__ = ValueError()  # a context, not a cause: not what the compiled call raised
    assert original_error(handled) is None


@pytest.mark.skipif(not hasattr(signal, "setitimer"), reason="needs POSIX interval timers")
def test_an_alarm_during_a_conflict_check_raises_its_exception_never_a_system_error() -> None:
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    sim.services.start()
    sim.stack("ASAS ON; MCRE 3000 EC35 1500 60")  # 3,000 aircraft: the detection pass takes milliseconds
    sim.run_until(1.0)
    service = sim.services.start().conflicts
    service.check(sim)  # compiled (or loaded) before any alarm
    rng = random.Random(0)
    outcomes: list[str] = []
    previous = signal.signal(signal.SIGALRM, _interrupt)
    try:
        while len(outcomes) < 30:
            try:
                signal.setitimer(signal.ITIMER_REAL, rng.uniform(0.001, 0.03))
                while True:
                    service.check(sim)
            except Interrupted:
                outcomes.append("Interrupted")
            except SystemError as exc:  # what the alarm ended as in most interrupted checks before
                outcomes.append(f"SystemError: {exc}")
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert outcomes == ["Interrupted"] * 30


CHILD = """
import json, logging, resource
logging.disable(logging.CRITICAL)
from aamsim import Simulation
sim = Simulation(seed=1, use_bluesky_navdata=False)
sim.services.start()
sim.stack("ASAS ON; ZONER 0.1; MCRE 3000 EC35 1500 60")  # few conflicts while the kernels warm up
sim.run_until(2.0)
sim.stack("ZONER 100")  # then every pair is one: the next check needs megabytes more
with open("/proc/self/status") as fh:
    now = next(int(line.split()[1]) * 1024 for line in fh if line.startswith("VmSize"))
resource.setrlimit(resource.RLIMIT_AS, (now, now))  # no more address space than the process has
sim.run_until(6.0)
print(json.dumps({"simt": sim.simt, "errors": [m.text for m in sim.reporter.errors()]}))
"""


@pytest.mark.skipif(not (hasattr(resource, "RLIMIT_AS") and Path("/proc/self/status").exists()),
                    reason="needs Linux address-space limits")
def test_a_conflict_check_out_of_memory_is_reported_and_the_run_goes_on() -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, env=env, timeout=600,
                          check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["simt"] == 6.0
    (error,) = result["errors"]  # once, however many checks were skipped
    assert error.startswith("conflict detection: out of memory at t = 3.00 s (3,000 aircraft); this check was "
                            "skipped")
