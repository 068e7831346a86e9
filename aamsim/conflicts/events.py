"""Columnar log of loss-of-separation events, updated with numpy per check.

Dense traffic can have thousands of pairs inside a volume at once; keeping
one Python object per pair and updating them one by one would cost more than
simulating. The log keeps one row per event in growable arrays, and the
events that are still open as a sorted array of integer pair keys.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class SeparationEvent:
    """One pair inside one volume, from entry to exit; positions at the closest point."""

    volume: str
    ac1: str
    ac2: str
    start_s: float
    end_s: float = math.nan
    min_dist_m: float = math.inf
    t_min_s: float = math.nan
    pos1: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    pos2: tuple[float, float, float] = (math.nan, math.nan, math.nan)

    @property
    def active(self) -> bool:
        return math.isnan(self.end_s)

    def duration_s(self, now_s: float) -> float:
        return (now_s if self.active else self.end_s) - self.start_s


def _grow(arr: np.ndarray, need: int) -> np.ndarray:
    if need <= len(arr):
        return arr
    new = np.full((max(need, 2 * len(arr), 64),) + arr.shape[1:], np.nan, dtype=arr.dtype)
    new[: len(arr)] = arr
    return new


@dataclass
class EventLog:
    """All events of one separation volume."""

    volume: str
    n: int = 0
    ac1: list[str] = field(default_factory=list)
    ac2: list[str] = field(default_factory=list)
    start: np.ndarray = field(default_factory=lambda: np.empty(0))
    end: np.ndarray = field(default_factory=lambda: np.empty(0))
    dmin: np.ndarray = field(default_factory=lambda: np.empty(0))
    tmin: np.ndarray = field(default_factory=lambda: np.empty(0))
    pos: np.ndarray = field(default_factory=lambda: np.empty((0, 6)))  # lat1, lon1, alt1, lat2, lon2, alt2
    open_keys: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))  # sorted
    open_rows: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    _cursor: int = 0  # rows before it ended before the last interval query

    def update(
        self,
        now: float,
        last_check: float,
        keys: np.ndarray,
        names1: list[str],
        names2: list[str],
        t_in: np.ndarray,
        t_out: np.ndarray,
        dmin: np.ndarray,
        t_min: np.ndarray,
        pos: np.ndarray,
        close_unseen: np.ndarray | None,
    ) -> None:
        """Merge one check's inside pairs into the log.

        Args:
            keys: pair keys of the pairs inside the volume during the interval.
            names1, names2: callsigns per pair (ac1 < ac2).
            t_in, t_out, dmin, t_min: entry/exit (relative to now), minimum distance and its time.
            pos: (m, 6) positions of ac1 and ac2 at the minimum.
            close_unseen: open keys that may be closed when not inside (None: all of them).
        """
        pos_open = np.searchsorted(self.open_keys, keys)
        found = np.zeros(len(keys), dtype=bool)
        inb = pos_open < len(self.open_keys)
        found[inb] = self.open_keys[pos_open[inb]] == keys[inb]
        rows = np.empty(len(keys), dtype=np.int64)
        rows[found] = self.open_rows[pos_open[found]]
        # New events.
        new = np.flatnonzero(~found)
        if len(new):
            first = self.n
            self._reserve(self.n + len(new))
            rows[new] = np.arange(first, first + len(new))
            self.start[rows[new]] = now + t_in[new]
            self.end[rows[new]] = np.nan
            self.dmin[rows[new]] = np.inf
            for k in new.tolist():
                self.ac1.append(names1[k])
                self.ac2.append(names2[k])
            self.n += len(new)
        # Closest approach so far.
        better = dmin < self.dmin[rows]
        rb = rows[better]
        self.dmin[rb] = dmin[better]
        self.tmin[rb] = now + t_min[better]
        self.pos[rb] = pos[better]
        # Pairs that left the volume inside this interval.
        left = t_out < -1e-9
        self.end[rows[left]] = now + t_out[left]
        still = keys[~left]
        still_rows = rows[~left]
        # Open events not inside during this interval ended at the last check.
        seen = np.isin(self.open_keys, keys)
        unseen = ~seen
        if close_unseen is not None:
            unseen &= np.isin(self.open_keys, close_unseen)
        self.end[self.open_rows[unseen]] = last_check if math.isfinite(last_check) else now
        keep = ~seen & ~unseen
        merged_keys = np.concatenate([self.open_keys[keep], still])
        merged_rows = np.concatenate([self.open_rows[keep], still_rows])
        order = np.argsort(merged_keys, kind="mergesort")
        self.open_keys = merged_keys[order]
        self.open_rows = merged_rows[order]

    def _reserve(self, need: int) -> None:
        self.start = _grow(self.start, need)
        self.end = _grow(self.end, need)
        self.dmin = _grow(self.dmin, need)
        self.tmin = _grow(self.tmin, need)
        self.pos = _grow(self.pos, need)

    def close_all(self, now: float, key_filter: np.ndarray | None = None) -> None:
        """End open events (all, or those with keys in ``key_filter``) at ``now``."""
        sel = np.ones(len(self.open_keys), bool) if key_filter is None else np.isin(self.open_keys, key_filter)
        self.end[self.open_rows[sel]] = now
        self.open_keys = self.open_keys[~sel]
        self.open_rows = self.open_rows[~sel]

    def involved_since(self, t0: float) -> dict[str, float]:
        """Callsign -> smallest distance, over events open at some time in [t0, now]."""
        while self._cursor < self.n and not math.isnan(self.end[self._cursor]) and self.end[self._cursor] < t0 - 1e-9:
            self._cursor += 1
        out: dict[str, float] = {}
        for r in range(self._cursor, self.n):
            e = self.end[r]
            if not math.isnan(e) and e < t0 - 1e-9:
                continue
            d = float(self.dmin[r])
            for a in (self.ac1[r], self.ac2[r]):
                if d < out.get(a, math.inf):
                    out[a] = d
        return out

    def open_callsigns(self) -> set[str]:
        out: set[str] = set()
        for r in self.open_rows.tolist():
            out.add(self.ac1[r])
            out.add(self.ac2[r])
        return out

    def event(self, r: int) -> SeparationEvent:
        p = self.pos[r]
        return SeparationEvent(self.volume, self.ac1[r], self.ac2[r], float(self.start[r]), float(self.end[r]),
                               float(self.dmin[r]), float(self.tmin[r]), (float(p[0]), float(p[1]), float(p[2])),
                               (float(p[3]), float(p[4]), float(p[5])))

    def events(self) -> list[SeparationEvent]:
        return [self.event(r) for r in range(self.n)]

    def durations_s(self, now: float) -> np.ndarray:
        end = np.where(np.isnan(self.end[: self.n]), now, self.end[: self.n])
        return end - self.start[: self.n]
