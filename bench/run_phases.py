"""Where the wall time of one ``aamsim run`` goes, phase by phase.

Runs ``aamsim run SCENARIO --until T`` in this process (exactly the CLI's
code path) with wall clocks around its parts, each counted exclusively (a
phase inside another is not counted twice)::

    python bench/run_phases.py SCENARIO --until 600          # the source tree this file is in
    python bench/run_phases.py SCENARIO --until 600 --root /path/to/other/checkout

Phases: the imports (numpy, Numba, aamsim); Numba's set-up
and the loading of cached machine code (the first load also initialises
Numba's compiler tables, a fixed cost per process); reading and parsing the
scenario; executing its commands; the step kernel; the conflict checks; the
trajectory samples and ``trajectories.csv``; the separation events, the
metrics and ``conflicts.csv``; the rest (hooks, bookkeeping, click). Warm up
first (one run) so that Numba's cache exists. The clocks cost about a
microsecond per wrapped call.
"""

from __future__ import annotations

import time

T_START = time.perf_counter()

import argparse
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

_totals: dict[str, float] = {}
_stack: list[list[float]] = []  # per open phase: [start, time of nested phases]


def _timed(phase: str, fn: Callable[..., Any]) -> Callable[..., Any]:
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        frame = [time.perf_counter(), 0.0]
        _stack.append(frame)
        try:
            return fn(*args, **kwargs)
        finally:
            _stack.pop()
            spent = time.perf_counter() - frame[0]
            _totals[phase] = _totals.get(phase, 0.0) + spent - frame[1]
            if _stack:
                _stack[-1][1] += spent

    return wrapper


def _wrap(owner: Any, name: str, phase: str) -> None:
    setattr(owner, name, _timed(phase, getattr(owner, name)))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario")
    parser.add_argument("--until", default="600")
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent,
                        help="aamsim source tree to run (default: this one)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(args.root))
    t0 = time.perf_counter()
    import numpy  # noqa: F401

    t1 = time.perf_counter()
    import numba  # noqa: F401

    t2 = time.perf_counter()
    from numba.core import caching

    _wrap(caching.Cache, "load_overload", "Numba set-up and cached code")

    def import_aamsim() -> None:
        import aamsim.cli  # noqa: F401

    _timed("import aamsim (and the CLI)", import_aamsim)()
    # The package's compiled functions load through their own dispatcher (aamsim/numba_cache.py), whose
    # cache object has its own load_overload: timed around the dispatcher's compile (a load or a compilation).
    try:
        from aamsim.numba_cache import SourceKeyedDispatcher
    except ImportError:  # an older tree
        pass
    else:
        _wrap(SourceKeyedDispatcher, "compile", "Numba set-up and cached code")
    import aamsim.cli
    from aamsim import services, simulation
    from aamsim.conflicts.service import ConflictService
    from aamsim.output.recorder import TrajectoryRecorder
    from aamsim.stack.executor import CommandExecutor

    _wrap(simulation.Simulation, "load_scenario", "reading and parsing the scenario")
    _wrap(CommandExecutor, "execute", "commands")
    _wrap(simulation, "advance", "step kernel")
    _wrap(ConflictService, "check", "conflict checks")
    _wrap(TrajectoryRecorder, "sample", "trajectories.csv")
    _wrap(TrajectoryRecorder, "flush", "trajectories.csv")
    _wrap(TrajectoryRecorder, "close", "trajectories.csv")  # the wait for its writer thread
    _wrap_outputs(services)
    with tempfile.TemporaryDirectory(prefix="run-phases-") as tmp:
        sys.argv = ["aamsim", "run", args.scenario, "--until", args.until, "--out", str(Path(tmp) / "run"), "--quiet"]
        before = sum(_totals.values())
        t4 = time.perf_counter()
        try:
            aamsim.cli.main()
        except SystemExit:
            pass
        t5 = time.perf_counter()
    rest = (t5 - t4) - (sum(_totals.values()) - before)
    rows = [("this script's own imports", t0 - T_START), ("import numpy", t1 - t0), ("import numba", t2 - t1)]
    rows += sorted(_totals.items(), key=lambda kv: -kv[1])
    rows.append(("the rest of the run (hooks, set-up, click)", rest))
    total = time.perf_counter() - T_START
    print(f"{args.scenario} until {args.until} s, aamsim from {args.root}: {total:.3f} s in this process "
          "(plus Python's own start, about 15 ms)")
    for name, seconds in rows:
        print(f"  {name:<38} {seconds:7.3f} s {100 * seconds / total:5.1f} %")
    return 0


def _wrap_outputs(services: Any) -> None:
    """The run's output step: events, metrics and conflicts.csv (wrapped where services.py calls them)."""
    from aamsim.conflicts.service import ConflictService
    from aamsim.metrics.service import MetricsService

    _wrap(services, "write_conflicts_csv", "events, metrics, conflicts.csv")
    _wrap(MetricsService, "compute", "events, metrics, conflicts.csv")
    prop = ConflictService.events
    ConflictService.events = property(_timed("events, metrics, conflicts.csv", prop.fget))  # type: ignore[assignment]


if __name__ == "__main__":
    raise SystemExit(main())
