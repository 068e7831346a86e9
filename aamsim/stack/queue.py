"""Pending timed commands, executed in time order (ties in insertion order)."""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass, field

from aamsim.stack.parser import TimedCommand

US_PER_S = 1_000_000


def to_us(t_s: float) -> int:
    """Seconds -> integer microseconds (the clock's unit); ValueError for a time that is not finite."""
    us = t_s * US_PER_S
    if not -9.2e18 < us < 9.2e18:  # NaN fails it too; one comparison (this runs every step)
        raise ValueError(f"time {t_s!r} s is not a finite time")
    return round(us)


@dataclass
class CommandQueue:
    """A stable priority queue of :class:`TimedCommand` keyed on due time."""

    _heap: list[tuple[int, int, TimedCommand]] = field(default_factory=list)
    _seq: itertools.count = field(default_factory=itertools.count)
    last_due_us: int | None = None  # due time of the last command popped (when the scenario last acted)

    def push(self, cmd: TimedCommand) -> None:
        heapq.heappush(self._heap, (to_us(cmd.time_s), next(self._seq), cmd))

    def extend(self, cmds: list[TimedCommand]) -> None:
        for cmd in cmds:
            self.push(cmd)

    def next_due_us(self) -> int | None:
        """Due time of the earliest pending command, or None."""
        return self._heap[0][0] if self._heap else None

    def pop_due(self, now_us: int) -> list[TimedCommand]:
        """Remove and return every command due at or before ``now_us``, in order."""
        due = []
        while self._heap and self._heap[0][0] <= now_us:
            t_us, _, cmd = heapq.heappop(self._heap)
            due.append(cmd)
            self.last_due_us = t_us
        return due

    def clear(self) -> None:
        self._heap.clear()

    def __len__(self) -> int:
        return len(self._heap)

    def pending(self) -> list[TimedCommand]:
        """All pending commands in execution order (a copy)."""
        return [c for _, _, c in sorted(self._heap)]
