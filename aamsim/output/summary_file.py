"""``summary.json``, written atomically: a provisional one while the run goes on, the final one at its end.

A run killed outright (``kill -9``, the machine's out-of-memory killer, a
batch system's hard limit) writes nothing at its end. So ``aamsim run``
writes a provisional summary before the first step and again every
:data:`PROVISIONAL_PERIOD_S` seconds of wall time: the run figures so far
(sim time reached, flights, aircraft-steps), marked ``"complete": false``.
The final summary, ``"complete": true`` with the metrics, replaces it.

Every write goes to a temporary file in the same directory, then replaces
``summary.json`` by a rename: a reader (or a kill) never meets half a file.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

PROVISIONAL_PERIOD_S = 5.0  # wall seconds between two provisional summaries


class IncompleteSummary(ValueError):
    """A provisional ``summary.json``: its run was killed (or is still running)."""


def write_json_atomic(path: Path, data: dict[str, Any]) -> None:
    """``data`` as indented JSON at ``path``, through a temporary file and a rename."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(json.dumps(data, indent=2, sort_keys=False) + "\n", encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def check_complete(summary: dict[str, Any], where: str) -> None:
    """Raise :class:`IncompleteSummary` when ``summary`` is a provisional one (``"complete": false``).

    Summaries written before provisional summaries existed have no ``complete`` field: they are final.
    """
    if summary.get("complete") is False:
        reached = summary.get("sim_time_s")
        at = f" at sim time {reached:.1f} s" if isinstance(reached, (int, float)) else ""
        raise IncompleteSummary(f"{where}: the run did not finish (provisional summary, last written{at}; "
                                "the run was killed or is still running)")


class ProvisionalSummary:
    """Writes the provisional summary when due (see the module docstring)."""

    def __init__(self, path: Path, make: Callable[[float], dict[str, Any]],
                 report: Callable[[str, str], None], period_s: float = PROVISIONAL_PERIOD_S,
                 clock: Callable[[], float] = time.perf_counter, before: Callable[[], None] | None = None):
        """``make(wall_s)``: the summary so far; ``before()``: runs before each write (the trajectory
        recorder writes its rows, so that the files on disk match the summary)."""
        self.path, self.make, self.report, self.period_s, self.clock = path, make, report, period_s, clock
        self.before = before
        self.writes = 0
        self._next = -float("inf")
        self._failed = False

    def write(self, wall_s: float) -> None:
        """Write it now (``wall_s``: the run's wall time so far)."""
        self._next = self.clock() + self.period_s
        try:
            if self.before is not None:
                self.before()
            write_json_atomic(self.path, {**self.make(wall_s), "complete": False})
        except OSError as exc:  # a full disk must not end the simulation; the final write reports again
            if not self._failed:
                self._failed = True
                self.report("warning", f"{self.path.parent}: provisional summary not written ({exc})")
            return
        self.writes += 1

    def maybe_write(self, wall_s: float) -> None:
        """Write it when :data:`PROVISIONAL_PERIOD_S` has passed since the last write."""
        if self.clock() >= self._next:
            self.write(wall_s)
