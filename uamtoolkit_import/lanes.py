"""Lane (cruise altitude) assignment: no head-on encounters by construction.

As in the paper, a flight between two vertiports gets a lane of its route
that no other airborne flight between the same pair (in either direction)
is using. The generator goes one step further so that the paper's claim
"this avoids head-on conflict" also holds between *different* pairs that
share a corridor: a lane is refused when an airborne flight on it would
fly one of the new flight's segments in the opposite direction at an
overlapping time (each segment's occupation is widened by ``margin_s``).
Among acceptable lanes the lowest is taken. Overtaking, merging and
crossing encounters remain: those are the conflicts a speed-control agent
can resolve.

A departure also needs a clear vertiport: a lane is refused while another
flight on it is predicted (flying its timed legs) within ``clearance_m`` of
the origin vertiport around the departure time, as a vertiport would hold a
take-off while traffic passes overhead or lands. Without this an aircraft can
be created on top of passing traffic: an NMAC no speed advisory can avoid.

Lane rules, in order: (1) free for the OD pair, no head-on overlap, clear
departure; (2) shared with same-direction flights of the pair, otherwise the
same; otherwise :meth:`LaneBook.choose` returns None and the caller waits.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from aamsim.units import R_EARTH

Leg = tuple[str, str, float, float]
"""A directed segment (from, to) and when it is flown: enter and exit times [s]."""


@dataclass(frozen=True)
class LaneUse:
    """A flight on a lane: its OD pair, airborne interval [s] and timed legs."""

    lane_ft: float
    origin: str
    destination: str
    dep_s: float
    arr_s: float
    legs: tuple[Leg, ...]


def timed_legs(path: Sequence[str], leg_lengths_m: Sequence[float], speed_mps: float, dep_s: float) -> tuple[Leg, ...]:
    """Legs of ``path`` with their enter/exit times at a constant speed from ``dep_s``."""
    legs = []
    t = dep_s
    for a, b, length in zip(path, path[1:], leg_lengths_m):
        t_next = t + length / speed_mps
        legs.append((a, b, t, t_next))
        t = t_next
    return tuple(legs)


@dataclass
class LaneBook:
    """The lanes in use by airborne flights.

    Attributes:
        margin_s: each segment occupation is widened by this much on both
            sides when looking for head-on overlaps [s] (it absorbs the
            acceleration after take-off and speed capping by the aircraft model).
        position: point id -> (lat, lon) [deg]; without it departures are not checked.
        clearance_m: a departure waits while traffic on its lane is predicted this close to the origin [m].
        clear_before_s, clear_after_s: the time window around the departure that must be clear [s]
            (wide: predicted times drift from the flown ones by tens of seconds).
    """

    margin_s: float = 120.0
    position: Callable[[str], tuple[float, float]] | None = None
    clearance_m: float = 600.0
    clear_before_s: float = 60.0
    clear_after_s: float = 90.0
    _active: list[LaneUse] = field(default_factory=list)

    def airborne(self, t_s: float) -> list[LaneUse]:
        """Flights that may still be airborne at ``t_s``."""
        return [u for u in self._active if u.arr_s + self.margin_s > t_s]

    def forget(self, before_s: float) -> None:
        """Drop flights that landed before ``before_s`` (call it with a time no later departure precedes)."""
        self._active = self.airborne(before_s)

    def _head_on(self, legs: Sequence[Leg], other: LaneUse) -> bool:
        m = self.margin_s
        reverse = {(b, a): (t0, t1) for a, b, t0, t1 in other.legs}
        for a, b, t0, t1 in legs:
            span = reverse.get((a, b))
            if span is not None and t0 - m < span[1] and span[0] < t1 + m:
                return True
        return False

    def _passes_near(self, legs: Sequence[Leg], site: str, t0: float, t1: float) -> bool:
        """Whether a flight on ``legs`` is predicted within ``clearance_m`` of point ``site`` between t0 and t1."""
        assert self.position is not None
        lat0, lon0 = self.position(site)
        coslat = math.cos(math.radians(lat0))

        def xy(point: str) -> tuple[float, float]:
            lat, lon = self.position(point)  # type: ignore[misc]
            return (math.radians(lon - lon0) * R_EARTH * coslat, math.radians(lat - lat0) * R_EARTH)

        for a, b, ta, tb in legs:
            lo, hi = max(ta, t0), min(tb, t1)
            if lo > hi or tb <= ta:
                continue
            (xa, ya), (xb, yb) = xy(a), xy(b)
            # The part of the leg flown inside the window, then its closest point to the site (origin).
            fa, fb = (lo - ta) / (tb - ta), (hi - ta) / (tb - ta)
            px, py = xa + fa * (xb - xa), ya + fa * (yb - ya)
            qx, qy = xa + fb * (xb - xa), ya + fb * (yb - ya)
            dx, dy = qx - px, qy - py
            seg2 = dx * dx + dy * dy
            u = 0.0 if seg2 == 0 else max(0.0, min(1.0, -(px * dx + py * dy) / seg2))
            if math.hypot(px + u * dx, py + u * dy) < self.clearance_m:
                return True
        return False

    def acceptable(
        self, origin: str, destination: str, lane_ft: float, legs: Sequence[Leg], t_s: float, pair_free: bool
    ) -> bool:
        """Whether a lane suits a flight (``pair_free``: also unused by the OD pair)."""
        pair = {origin, destination}
        for use in self.airborne(t_s - self.clear_before_s):
            if use.lane_ft != lane_ft:
                continue
            if pair_free and {use.origin, use.destination} == pair and use.arr_s + self.margin_s > t_s:
                return False
            if self._head_on(legs, use):
                return False
            if self.position is not None and self._blocks_departure(legs, origin, t_s, use):
                return False
        return True

    def _blocks_departure(self, legs: Sequence[Leg], origin: str, t_s: float, other: LaneUse) -> bool:
        """Whether either flight would pass over the other's origin around its departure time."""
        if self._passes_near(other.legs, origin, t_s - self.clear_before_s, t_s + self.clear_after_s):
            return True
        # A flight booked earlier may depart later than this one (it waited for a lane).
        return self._passes_near(legs, other.origin, other.dep_s - self.clear_before_s,
                                 other.dep_s + self.clear_after_s)

    def choose(
        self, origin: str, destination: str, lanes_ft: Sequence[float], legs: Sequence[Leg], t_s: float
    ) -> float | None:
        """The lane [ft] for a flight departing at ``t_s`` with timed ``legs``, or None to wait."""
        if not lanes_ft:
            raise ValueError(f"no lane is common to every segment from {origin} to {destination}")
        for pair_free in (True, False):
            for lane in sorted(lanes_ft):
                if self.acceptable(origin, destination, lane, legs, t_s, pair_free):
                    return lane
        return None

    def least_conflicting(self, lanes_ft: Sequence[float], legs: Sequence[Leg], t_s: float) -> float:
        """The lane with the fewest head-on overlaps (last resort; lowest at a tie)."""

        def overlaps(lane: float) -> int:
            return sum(1 for u in self.airborne(t_s) if u.lane_ft == lane and self._head_on(legs, u))

        return min(sorted(lanes_ft), key=overlaps)

    def occupy(self, use: LaneUse) -> None:
        """Record a flight on its lane."""
        self._active.append(use)
