"""Helpers of the bridge tests: a small conflict scenario, servers in threads and subprocesses."""

from __future__ import annotations

import contextlib
import math
import os
import queue
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import zmq

from rlbridge.server import ServerOptions, SimulationServer

ROOT = Path(__file__).resolve().parents[1]

# Two crossing pairs that meet (NMAC and LoWC), one pair in trail, staggered creation, arrivals that delete.
CONFLICT_SCN = """\
00:00:00.00>DEFWPT XA 40.700000 -73.960000
00:00:00.00>DEFWPT XB 40.730000 -73.990000
00:00:00.00>CRE A1 EC35 40.700000 -74.020000 90 1000 100
00:00:00.00>DEST A1 XA
00:00:00.00>A1 ATDIST XA 0.05 DEL A1
00:00:00.00>CRE B1 EC35 40.677000 -73.990000 0 1000 100
00:00:00.00>DEST B1 XB
00:00:00.00>B1 ATDIST XB 0.05 DEL B1
00:00:20.00>CRE C1 EC35 40.700000 -74.020000 90 1000 120
00:00:20.00>DEST C1 XA
00:00:20.00>C1 ATDIST XA 0.05 DEL C1
00:00:45.00>CRE D1 EC35 40.730000 -73.990000 180 1050 90
00:00:45.00>ADDWPT D1 40.700000 -73.990000
00:00:45.00>ADDWPT D1 40.677000 -73.990000
00:00:45.00>D1 ATDIST 40.677000 -73.990000 0.05 DEL D1
00:01:10.00>CRE E1 EC35 40.677000 -73.990000 0 1000 110
00:01:10.00>DEST E1 XB
00:01:10.00>E1 ATDIST XB 0.05 DEL E1
"""


def write_scenario(folder: Path, name: str = "conflicts.scn", text: str = CONFLICT_SCN) -> Path:
    path = folder / name
    path.write_text(text)
    return path


@contextlib.contextmanager
def thread_server(**options: Any) -> Iterator[SimulationServer]:
    """A server on a random loopback port, served by a thread of this process."""
    server = SimulationServer(ServerOptions(bind="tcp://127.0.0.1:*", **options))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield server
    finally:
        server.stop()
        thread.join(10)
        assert not thread.is_alive(), "server thread did not stop"


def spawn_server(*args: str, cwd: Path | None = None, timeout_s: float = 60.0) -> tuple[subprocess.Popen, str]:
    """``python -m aamsim serve`` on a random loopback port; returns the process and its endpoint."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "aamsim", "serve", "--bind", "tcp://127.0.0.1:*", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=cwd)
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout], daemon=True).start()
    try:
        line = lines.get(timeout=timeout_s)
    except queue.Empty:
        proc.kill()
        raise RuntimeError(f"server did not start: {proc.stderr.read() if proc.poll() is not None else ''}")
    if "listening on " not in line:
        proc.kill()
        raise RuntimeError(f"unexpected server output {line!r}")
    return proc, line.split("listening on ", 1)[1].strip()


def stop_process(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.kill()
    proc.wait(10)


# How long a test waits for a reply that needs real work (a reset): the first reset of a process loads
# or compiles the Numba kernels, 68 s measured on a machine at load 19. A test asserts what the reply
# says; a reply that never comes still fails it, after this long instead of hanging.
REPLY_TIMEOUT_MS = 600_000


@contextlib.contextmanager
def raw_socket(endpoint: str, kind: int = zmq.DEALER, timeout_ms: int = 5000) -> Iterator[zmq.Socket]:
    """A plain pyzmq socket with linger 0 and send/receive timeouts."""
    ctx = zmq.Context()
    sock = ctx.socket(kind)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVTIMEO, timeout_ms)
    sock.setsockopt(zmq.SNDTIMEO, timeout_ms)
    sock.connect(endpoint)
    try:
        yield sock
    finally:
        sock.close(0)
        ctx.term()


def rollout(env: Any, seed: int, steps: int, action_seed: int = 0) -> list[tuple]:
    """A parallel env's trajectory under seeded random actions (obs, rewards, flags, infos per step)."""
    rng = np.random.default_rng(action_seed)
    obs, infos = env.reset(seed=seed)
    out = [(obs, infos)]
    for _ in range(steps):
        if not env.agents:
            break
        actions = {a: int(rng.integers(3)) for a in env.agents}
        out.append(env.step(actions))
    return out


def assert_same(a: Any, b: Any) -> None:
    """Exact equality, arrays compared by dtype, shape and bytes (NaN equal to NaN)."""
    if isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape, (a, b)
        assert a.tobytes() == b.tobytes()
    elif isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), (a, b)
        for k in a:
            assert_same(a[k], b[k])
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), (a, b)
        for x, y in zip(a, b):
            assert_same(x, y)
    elif isinstance(a, float) and math.isnan(a):
        assert isinstance(b, float) and math.isnan(b)
    else:
        assert type(a) is type(b) and a == b, (a, b)


def run_cli(*args: str, cwd: Path | None = None, extra_path: Path | None = None) -> subprocess.CompletedProcess:
    """``python -m aamsim ARGS`` as a user runs it."""
    path = str(ROOT) if extra_path is None else os.pathsep.join((str(ROOT), str(extra_path)))
    env = dict(os.environ, PYTHONPATH=path)
    return subprocess.run([sys.executable, "-m", "aamsim", *args], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=120, check=False)
