"""How many threads step the traffic: the ``threads`` argument, ``--threads`` or ``AAMSIM_THREADS``.

One place checks the number for every entry point (:class:`aamsim.Simulation`,
:class:`aamsim.worlds.WorldSet`, ``aamsim run --threads``, the environments'
``threads`` parameter): at least 1 and at most the CPU cores this process may
run on. More threads than cores would only wait for each other (a thread count
above the cores is an error, not a silent slow-down).
"""

from __future__ import annotations

import os

THREADS_ENV = "AAMSIM_THREADS"


def available_cores() -> int:
    """CPU cores this process may run on (its affinity where the OS tells it), capped by Numba's thread pool."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        cores = os.cpu_count() or 1
    import numba

    return max(1, min(cores, int(numba.config.NUMBA_NUM_THREADS)))  # type: ignore[attr-defined]


def check_threads(threads: int | None = None) -> int:
    """The thread count to use: ``threads``, or ``AAMSIM_THREADS`` when None (default 1); a clear error
    when it is not a whole number (TypeError; ValueError for the variable's text) or not between 1 and
    the cores available (ValueError)."""
    source = "threads"
    if threads is None:
        text = os.environ.get(THREADS_ENV, "").strip()
        if not text:
            return 1
        source = THREADS_ENV
        try:
            threads = int(text)
        except ValueError:
            raise ValueError(f"{THREADS_ENV}={text!r} is not a whole number of threads") from None
    if isinstance(threads, bool) or not isinstance(threads, int):
        raise TypeError(f"{source} must be a whole number, not {threads!r}")
    cores = available_cores()
    if not 1 <= threads <= cores:
        raise ValueError(f"{source} = {threads}: must be between 1 and {cores}, the CPU cores available "
                         "to this process")
    return threads
