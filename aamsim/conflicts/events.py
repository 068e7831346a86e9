"""Columnar log of loss-of-separation events, updated by one compiled merge per check.

Dense traffic can have thousands of pairs inside a volume at once; keeping
one Python object per pair and updating them one by one would cost more than
simulating. The log keeps one row per event in growable arrays, and the
events that are still open as a sorted array of integer pair keys.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from aamsim.numba_cache import njit


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
    pos1: tuple[float, float, float] = (math.nan, math.nan, math.nan)  # lat, lon, alt [m]
    pos2: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    vel1: tuple[float, float, float] = (math.nan, math.nan, math.nan)  # east, north, up [m/s]
    vel2: tuple[float, float, float] = (math.nan, math.nan, math.nan)

    @property
    def active(self) -> bool:
        return math.isnan(self.end_s)

    def duration_s(self, now_s: float) -> float:
        return (now_s if self.active else self.end_s) - self.start_s

    @property
    def encounter(self) -> str:
        """The geometry at the closest point (:func:`encounter_type`)."""
        return encounter_type(self.vel1, self.vel2)


def track_speed(vel: tuple[float, float, float]) -> tuple[float, float, float]:
    """Track [deg], ground speed and vertical speed [m/s] from an (east, north, up) velocity."""
    east, north, up = vel
    return math.degrees(math.atan2(east, north)) % 360.0, math.hypot(east, north), up


def encounter_type(vel1: tuple[float, float, float], vel2: tuple[float, float, float]) -> str:
    """Classify an encounter by the two velocities at the closest point.

    ``hover`` when one aircraft is (almost) stopped, ground speed under 1 m/s;
    ``vertical`` when one climbs or descends faster than 1 m/s; otherwise by the
    angle between the tracks: ``same-direction`` under 30 deg (in-trail,
    overtaking, merging), ``head-on`` over 150 deg, ``crossing`` in between.
    Empty when the velocities are unknown.
    """
    if any(math.isnan(x) for x in vel1 + vel2):
        return ""
    return classify_encounter(*track_speed(vel1), *track_speed(vel2))


def classify_encounter(trk1: float, gs1: float, vs1: float, trk2: float, gs2: float, vs2: float) -> str:
    """:func:`encounter_type` from both aircraft's :func:`track_speed` (velocities known)."""
    if min(gs1, gs2) < 1.0:
        return "hover"
    if max(abs(vs1), abs(vs2)) > 1.0:
        return "vertical"
    angle = abs((trk1 - trk2 + 180.0) % 360.0 - 180.0)
    if angle < 30.0:
        return "same-direction"
    return "head-on" if angle > 150.0 else "crossing"


@njit(cache=True)
def _merge(open_keys: np.ndarray, open_rows: np.ndarray, ii: np.ndarray, jj: np.ndarray, serial: np.ndarray,
           rank: np.ndarray, t_in: np.ndarray, t_out: np.ndarray, dmin: np.ndarray, t_min: np.ndarray,
           cpa: np.ndarray, now: float, last: float, n: int, start: np.ndarray, end: np.ndarray,
           log_dmin: np.ndarray, log_tmin: np.ndarray, log_cpa: np.ndarray, close_all_unseen: bool,
           close_filter: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One check's inside pairs merged into the open events (sorted keys) and the row arrays.

    Rows from ``n`` on are free (reserved by the caller). Returns the new open
    keys and rows and, for the events opened, the slots of ac1 and ac2.
    """
    m = ii.shape[0]
    keys = np.empty(m, dtype=np.int64)
    for k in range(m):
        a, b = serial[ii[k]], serial[jj[k]]
        keys[k] = min(a, b) * (np.int64(1) << 32) + max(a, b)
    order = np.argsort(keys)
    o = open_keys.shape[0]
    new_keys = np.empty(o + m, dtype=np.int64)
    new_rows = np.empty(o + m, dtype=np.int64)
    first = np.empty(m, dtype=np.int64)
    second = np.empty(m, dtype=np.int64)
    n_open = 0
    n_new = 0
    a = 0  # walks the open keys (sorted) alongside this check's keys (sorted)
    f = 0  # walks the close filter (sorted)
    for r in range(m + 1):
        key = keys[order[r]] if r < m else np.int64(0x7FFFFFFFFFFFFFFF)
        # Open events with smaller keys were not inside during this interval.
        while a < o and (r == m or open_keys[a] < key):
            k = open_keys[a]
            closing = close_all_unseen
            if not closing:
                while f < close_filter.shape[0] and close_filter[f] < k:
                    f += 1
                closing = f < close_filter.shape[0] and close_filter[f] == k
            if closing:
                end[open_rows[a]] = last  # ended at the last check
            else:
                new_keys[n_open] = k
                new_rows[n_open] = open_rows[a]
                n_open += 1
            a += 1
        if r == m:
            break
        q = order[r]
        swap = rank[ii[q]] > rank[jj[q]]
        if a < o and open_keys[a] == key:
            row = open_rows[a]
            a += 1
        else:
            row = n + n_new
            first[n_new] = jj[q] if swap else ii[q]
            second[n_new] = ii[q] if swap else jj[q]
            n_new += 1
            start[row] = now + t_in[q]
            end[row] = np.nan
            log_dmin[row] = np.inf
        if dmin[q] < log_dmin[row]:
            log_dmin[row] = dmin[q]
            log_tmin[row] = now + t_min[q]
            for c in (0, 1, 2, 6, 7, 8):
                log_cpa[row, c] = cpa[q, c + 3] if swap else cpa[q, c]
                log_cpa[row, c + 3] = cpa[q, c] if swap else cpa[q, c + 3]
        if t_out[q] < -1e-9:
            end[row] = now + t_out[q]  # left the volume inside this interval
        else:
            new_keys[n_open] = key
            new_rows[n_open] = row
            n_open += 1
    return new_keys[:n_open].copy(), new_rows[:n_open].copy(), first[:n_new].copy(), second[:n_new].copy()


_NO_KEYS = np.empty(0, dtype=np.int64)
_FEW_ROWS = 32  # involved_since answers up to this many candidate rows in Python (see _involved_few)


def _grow(arr: np.ndarray, need: int) -> np.ndarray:
    if need <= len(arr):
        return arr
    fill = np.nan if arr.dtype.kind == "f" else -1
    new = np.full((max(need, 2 * len(arr), 64),) + arr.shape[1:], fill, dtype=arr.dtype)
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
    # State at the closest point: lat1, lon1, alt1, lat2, lon2, alt2, then east, north, up velocity of ac1, of ac2.
    cpa: np.ndarray = field(default_factory=lambda: np.empty((0, 12)))
    serial1: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))  # ac1's serial (per run)
    serial2: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    open_keys: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))  # sorted
    open_rows: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    _cursor: int = 0  # rows before it ended before the last interval query

    def update(
        self,
        now: float,
        last_check: float,
        ids: list[str],
        ii: np.ndarray,
        jj: np.ndarray,
        serial: np.ndarray,
        rank: np.ndarray,
        t_in: np.ndarray,
        t_out: np.ndarray,
        dmin: np.ndarray,
        t_min: np.ndarray,
        cpa: np.ndarray,
        close_unseen: np.ndarray | None,
    ) -> None:
        """Merge one check's inside pairs into the log.

        Args:
            ids: callsign per slot; ii, jj: the slots of each pair inside the volume during the interval.
            serial: per slot, a number unique to the aircraft over the run (pair keys are built from it).
            rank: per slot, the callsign's rank in sorting order (events name the pair in that order).
            t_in, t_out, dmin, t_min: entry/exit (relative to now), minimum distance and its time.
            cpa: (m, 12) state at the minimum: positions (lat, lon, alt) of the aircraft in slots ii
                and jj, then their velocities (east, north, up).
            close_unseen: open keys that may be closed when not inside (None: all of them).
        """
        self._reserve(self.n + len(ii))
        last = last_check if math.isfinite(last_check) else now
        filt = np.sort(close_unseen) if close_unseen is not None else _NO_KEYS
        self.open_keys, self.open_rows, first, second = _merge(
            self.open_keys, self.open_rows, ii, jj, serial, rank, t_in, t_out, dmin, t_min, cpa, now, last, self.n,
            self.start, self.end, self.dmin, self.tmin, self.cpa, close_unseen is None, filt)
        n_new = len(first)
        if not n_new:  # most checks start no event: skip the writes' fixed costs
            return
        for a, b in zip(first.tolist(), second.tolist()):
            self.ac1.append(ids[a])
            self.ac2.append(ids[b])
        self.serial1[self.n:self.n + n_new] = serial[first]
        self.serial2[self.n:self.n + n_new] = serial[second]
        self.n += n_new

    def _reserve(self, need: int) -> None:
        if need <= len(self.start):
            return
        self.start = _grow(self.start, need)
        self.end = _grow(self.end, need)
        self.dmin = _grow(self.dmin, need)
        self.tmin = _grow(self.tmin, need)
        self.cpa = _grow(self.cpa, need)
        self.serial1 = _grow(self.serial1, need)
        self.serial2 = _grow(self.serial2, need)

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
        # In arrays, not row by row: a dense check can leave 100,000 events open (MAX_PAIRS_PER_CHECK).
        lo = self._cursor
        if lo == self.n:
            return {}
        if self.n - lo <= _FEW_ROWS:
            return self._involved_few(lo, t0)
        end = self.end[lo:self.n]
        rows = lo + np.flatnonzero(~(end < t0 - 1e-9))  # open (NaN) or ended at or after t0
        if not len(rows):
            return {}
        serials = np.concatenate([self.serial1[rows], self.serial2[rows]])
        dist = np.concatenate([self.dmin[rows], self.dmin[rows]])
        where = np.concatenate([rows, rows])
        side = np.repeat(np.array([0, 1]), len(rows))
        order = np.lexsort((dist, serials))  # by aircraft, then distance: the first of each is its smallest
        first = order[np.concatenate([[True], serials[order][1:] != serials[order][:-1]])]
        names = (self.ac1, self.ac2)
        return {names[s][r]: d for s, r, d in zip(side[first].tolist(), where[first].tolist(),
                                                   dist[first].tolist())}

    def _involved_few(self, lo: int, t0: float) -> dict[str, float]:
        """:meth:`involved_since` over the rows ``lo..n`` in Python: the same answer, in the same order.

        The usual case (a few events since the last open one) costs a few microseconds this way; the
        array pass has a fixed cost of about 30 (the vector environments ask twice per world and step).
        """
        hi = self.n
        limit = t0 - 1e-9
        best: dict[int, tuple[float, str]] = {}  # serial -> (smallest distance, callsign)
        for r, e, d, s1, s2 in zip(range(lo, hi), self.end[lo:hi].tolist(), self.dmin[lo:hi].tolist(),
                                    self.serial1[lo:hi].tolist(), self.serial2[lo:hi].tolist()):
            if e < limit:  # ended before t0 (an open event's end is NaN)
                continue
            for serial, name in ((s1, self.ac1[r]), (s2, self.ac2[r])):
                old = best.get(serial)
                # The array pass sorts by distance with NaN last: a number replaces a NaN, never the reverse.
                if old is None or d < old[0] or (math.isnan(old[0]) and not math.isnan(d)):
                    best[serial] = (d, name)
        return {best[s][1]: best[s][0] for s in sorted(best)}

    def open_callsigns(self) -> set[str]:
        out: set[str] = set()
        for r in self.open_rows.tolist():
            out.add(self.ac1[r])
            out.add(self.ac2[r])
        return out

    def event(self, r: int) -> SeparationEvent:
        p = [float(x) for x in self.cpa[r]]
        return SeparationEvent(self.volume, self.ac1[r], self.ac2[r], float(self.start[r]), float(self.end[r]),
                               float(self.dmin[r]), float(self.tmin[r]), (p[0], p[1], p[2]), (p[3], p[4], p[5]),
                               (p[6], p[7], p[8]), (p[9], p[10], p[11]))

    def events(self) -> list[SeparationEvent]:
        n = self.n
        # Whole columns to Python floats at once (tolist), not element by element: dense runs log tens of thousands.
        starts, ends, dmins, tmins = (a[:n].tolist() for a in (self.start, self.end, self.dmin, self.tmin))
        return [SeparationEvent(self.volume, a1, a2, t0, t1, d, tm, (p[0], p[1], p[2]), (p[3], p[4], p[5]),
                                (p[6], p[7], p[8]), (p[9], p[10], p[11]))
                for a1, a2, t0, t1, d, tm, p in zip(self.ac1, self.ac2, starts, ends, dmins, tmins,
                                                    self.cpa[:n].tolist())]

    def durations_s(self, now: float) -> np.ndarray:
        end = np.where(np.isnan(self.end[: self.n]), now, self.end[: self.n])
        return end - self.start[: self.n]
