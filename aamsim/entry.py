"""The ``aamsim`` command as a whole process (``python -m aamsim`` and the console script).

A finished ``aamsim run`` leaves without tearing the interpreter down: after
loading compiled code, Python's shutdown spends 60-90 ms freeing Numba's
compiler tables and LLVM's modules one object at a time, a sixth of a short
run's wall time, with nothing left to write. The exit handlers still run
(temporary files, logging, plugins' ``atexit`` functions) and the standard
streams are flushed; only the freeing of memory is left to the operating
system. Any other command, a run that ends with an exception, or one with
other threads still running exits the usual way. :func:`aamsim.cli.main` (the
click group, what tests and embedding code call) is unchanged.

The objects of the imports (numpy, Numba, click, the package: about 60,000
that the cyclic garbage collector tracks) live as long as the process. They
are frozen out of the collector's sight (:func:`gc.freeze`) before the command
runs: a full collection, which fell in almost every ``aamsim run`` and walked
them all, took 50-70 ms (with one aircraft, a tenth of the run). Whole process,
``bench/bench_sim.py --whole-process``: 1.13x faster with one aircraft for 1 s,
1.03x with 100 for 1 h. Garbage made later is collected as usual.
"""

from __future__ import annotations

import atexit
import gc
import os
import sys
import threading


def _exit_status(code: object) -> int:
    """The process status ``sys.exit(code)`` gives (None: 0; text: printed, 1)."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)
    return 1


def _only_thread() -> bool:
    return all(t is threading.current_thread() or t.daemon or not t.is_alive() for t in threading.enumerate())


def main(argv: list[str] | None = None) -> None:
    """Run the command line; after ``run``, leave without the interpreter's teardown (see the module doc)."""
    from aamsim.cli import main as cli

    gc.freeze()  # the imports' objects stay for good: no full collection walks them again (module doc)
    args = sys.argv[1:] if argv is None else argv
    try:
        cli.main(args=argv)  # standalone: always ends in SystemExit
        code: object = 0
    except SystemExit as exc:
        code = exc.code
    if not args or args[0] != "run" or not _only_thread():
        sys.exit(code)
    status = _exit_status(code)
    atexit._run_exitfuncs()  # what an ordinary exit runs before the teardown
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can reach it
            pass
    os._exit(status)
