"""Flight plans: the ordered waypoints of one aircraft.

A route is edited by stack commands (ADDWPT, DEST, ORIG, DELWPT, AT ...)
between steps, so it is plain Python data; only the active leg lives in the
traffic arrays where the step kernel reads it. Altitude and speed
constraints are NaN when absent. :meth:`Route.plan` derives, for each
waypoint, the next altitude constraint along the route and the distance to it
(the "ruler" VNAV uses to place top of climb and descent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import Any

from aamsim.geo import qdrdist


TURN_VALUES = ("bank", "radius", "speed", "rate")


@dataclass(frozen=True)
class TurnSpec:
    """What was given for a fly-turn waypoint's turn (BlueSky's TURNBANK/TURNRAD/TURNSPD/TURNHDG; NaN: not given).

    At most two are given at a time: setting a third drops the oldest
    (:meth:`Route.set_turn_value`); the others follow from them.
    """

    bank_deg: float = math.nan
    radius_m: float = math.nan
    speed_cas: float = math.nan  # m/s
    rate_dps: float = math.nan  # deg/s

    def given(self) -> tuple[str, ...]:
        """Names (of :data:`TURN_VALUES`) of the values given."""
        values = (self.bank_deg, self.radius_m, self.speed_cas, self.rate_dps)
        return tuple(name for name, v in zip(TURN_VALUES, values) if v > 0.0)

    def with_value(self, name: str, value: float) -> TurnSpec:
        field_name = {"bank": "bank_deg", "radius": "radius_m", "speed": "speed_cas", "rate": "rate_dps"}[name]
        return replace(self, **{field_name: value})


class WaypointKind(Enum):
    LATLON = "latlon"
    NAV = "nav"
    ORIG = "orig"
    DEST = "dest"


@dataclass
class Waypoint:
    """One waypoint; alt/spd are constraints at it (NaN: none)."""

    name: str
    kind: WaypointKind
    lat: float
    lon: float
    alt: float = math.nan  # m
    spd: float = math.nan  # CAS m/s, or Mach when spd_mach
    spd_mach: bool = False
    flyby: bool = True
    turn: TurnSpec | None = None  # a fly-turn waypoint's turn (None: fly-by or fly-over)
    rta_s: float = math.nan  # required time of arrival [s], book-keeping
    stack: list[str] = field(default_factory=list)
    stack_sources: list[Any] = field(default_factory=list)  # SourceRef of the AT line of each stack entry
    # Derived by Route.plan():
    toalt: float = math.nan  # m, next altitude constraint from here on
    xtoalt: float = 0.0  # m, distance from here to that constraint
    dist_to: float = 0.0  # m, length of the leg ending here


@dataclass
class Route:
    """Waypoints of one aircraft and the index of the active one (-1: none)."""

    acid: str
    waypoints: list[Waypoint] = field(default_factory=list)
    iactwp: int = -1
    flyby_mode: bool = True  # FLYBY/FLYOVER mode for waypoints added from now on
    flyturn_mode: bool = False  # FLYTURN mode (then flyby_mode is False)
    turn_values: TurnSpec = field(default_factory=TurnSpec)  # for fly-turn waypoints added from now on
    _turn_order: list[str] = field(default_factory=list, repr=False)  # the last two turn values set

    def __len__(self) -> int:
        return len(self.waypoints)

    def set_mode(self, mode: str) -> None:
        """``FLYBY``, ``FLYOVER`` or ``FLYTURN`` for the waypoints added from now on."""
        self.flyby_mode = mode == "FLYBY"
        self.flyturn_mode = mode == "FLYTURN"

    def set_turn_value(self, name: str, value: float) -> None:
        """Set (``value`` > 0) or clear (NaN) one turn value; FLYTURN mode goes on.

        Only the last two values set are kept, as in BlueSky: setting a third
        clears the one set longest ago.
        """
        values = self.turn_values.with_value(name, value)
        order = [n for n in self._turn_order if n != name]
        if value > 0.0:
            order.append(name)
            if len(order) > 2:
                values = values.with_value(order.pop(0), math.nan)
        self.turn_values, self._turn_order = values, order
        self.set_mode("FLYTURN")

    def reset_modes(self) -> None:
        """Back to fly-by with no turn values (a deleted route, as BlueSky's DELRTE)."""
        self.set_mode("FLYBY")
        self.turn_values, self._turn_order = TurnSpec(), []

    @property
    def mode(self) -> str:
        return "FLYTURN" if self.flyturn_mode else "FLYBY" if self.flyby_mode else "FLYOVER"

    def new_waypoint_turn(self) -> tuple[bool, TurnSpec | None]:
        """``(flyby, turn)`` of a waypoint added now."""
        return self.flyby_mode, (self.turn_values if self.flyturn_mode else None)

    def next_turn_index(self) -> int:
        """Index of the first fly-turn waypoint from the active one on (-1: none)."""
        for k in range(max(self.iactwp, 0), len(self.waypoints)):
            if self.waypoints[k].turn is not None:
                return k
        return -1

    @property
    def names(self) -> list[str]:
        return [w.name for w in self.waypoints]

    def find(self, name: str) -> int:
        """Index of a waypoint by name, or -1."""
        name = name.upper()
        for i, w in enumerate(self.waypoints):
            if w.name == name:
                return i
        return -1

    @property
    def has_dest(self) -> bool:
        return bool(self.waypoints) and self.waypoints[-1].kind is WaypointKind.DEST

    @property
    def has_orig(self) -> bool:
        return bool(self.waypoints) and self.waypoints[0].kind is WaypointKind.ORIG

    def unique_name(self, base: str, digits: int, taken_callsigns: set[str] | frozenset[str] = frozenset()) -> str:
        """A waypoint name not yet in the route: ``base`` or ``base`` + counter.

        Lat/lon waypoints are named after the callsign with a three-digit
        counter (``KL204001``), as in BlueSky; a repeated navaid gets a two-digit one.
        """
        names = set(self.names)
        if base not in names and base not in taken_callsigns:
            return base
        counter = 1
        while True:
            candidate = f"{base}{counter:0{digits}d}"
            if candidate not in names:
                return candidate
            counter += 1

    def insert(self, index: int, wp: Waypoint) -> None:
        self.waypoints.insert(index, wp)

    def delete(self, index: int) -> None:
        del self.waypoints[index]
        if self.iactwp > index:
            self.iactwp = max(0, self.iactwp - 1)
        self.iactwp = min(self.iactwp, len(self.waypoints) - 1)

    def next_leg_qdr(self) -> float:
        """Direction [deg] of the leg after the active waypoint (NaN if none)."""
        i = self.iactwp
        if -1 < i < len(self.waypoints) - 1:
            a, b = self.waypoints[i], self.waypoints[i + 1]
            return qdrdist(a.lat, a.lon, b.lat, b.lon)[0]
        return math.nan

    def plan(self) -> None:
        """Recompute leg lengths and, per waypoint, the next altitude constraint.

        Walking backwards from the destination: a waypoint with an altitude
        constraint (the destination counts, at its altitude) resets the ruler;
        others add their outgoing leg to the distance to the next constraint.
        """
        wps = self.waypoints
        for i in range(1, len(wps)):
            wps[i].dist_to = qdrdist(wps[i - 1].lat, wps[i - 1].lon, wps[i].lat, wps[i].lon)[1]
        if wps:
            wps[0].dist_to = 0.0
        toalt = math.nan
        xtoalt = 0.0
        last = len(wps) - 1
        for i in range(last, -1, -1):
            wp = wps[i]
            if wp.kind is WaypointKind.DEST:
                toalt, xtoalt = (wp.alt if not math.isnan(wp.alt) else 0.0), 0.0
            elif not math.isnan(wp.alt):
                toalt, xtoalt = wp.alt, 0.0
            elif i != last:
                xtoalt += wps[i + 1].dist_to
            else:
                xtoalt = 0.0
            wp.toalt = toalt
            wp.xtoalt = xtoalt
