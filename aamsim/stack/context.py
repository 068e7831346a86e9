"""Parse contexts: what argument parsers may ask while binding a command.

:class:`LiveContext` answers from a running simulation; :class:`StaticContext`
answers from a scenario file alone (callsigns created by CRE lines, waypoints
defined by DEFWPT lines), for ``--strict`` validation before simulating.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from aamsim.errors import UnknownAircraft
from aamsim.stack.argtypes import Position

if TYPE_CHECKING:
    from aamsim.simulation import Simulation


@dataclass
class LiveContext:
    sim: Simulation
    last_acidx: int = -1
    ref_lat: float = 0.0
    ref_lon: float = 0.0

    def aircraft_index(self, acid: str) -> int:
        i = self.sim.traffic.index(acid)
        self.ref_lat = float(self.sim.traffic.lat[i])
        self.ref_lon = float(self.sim.traffic.lon[i])
        return i

    def named_position(self, name: str) -> Position | None:
        traffic = self.sim.traffic
        i = traffic.find(name)
        if i is not None:
            return Position(float(traffic.lat[i]), float(traffic.lon[i]), name, "aircraft")
        found = self.sim.navdb.lookup(name, self.ref_lat, self.ref_lon)
        if found is None:
            return None
        return Position(found[0], found[1], name, "waypoint")

    def route_has_waypoint(self, acidx: int, name: str) -> bool:
        if acidx < 0:
            return False
        return self.sim.traffic.routes[acidx].find(name) >= 0

    def note_reference(self, lat: float, lon: float) -> None:
        self.ref_lat, self.ref_lon = lat, lon


@dataclass
class StaticContext:
    """Validation without a simulation: every name the file could define is accepted."""

    callsigns: set[str] = field(default_factory=set)
    waypoints: set[str] = field(default_factory=set)
    any_callsign: bool = False  # MCRE makes random callsigns: accept any
    last_acidx: int = -1
    navdb_known: object = None  # callable(name) -> bool, for navdata names

    def aircraft_index(self, acid: str) -> int:
        if self.any_callsign or acid.upper() in self.callsigns:
            return 0
        raise UnknownAircraft(acid)

    def named_position(self, name: str) -> Position | None:
        name = name.upper()
        if name in self.waypoints or name in self.callsigns or self.any_callsign:
            return Position(0.0, 0.0, name, "waypoint")
        known = self.navdb_known
        if callable(known) and known(name):
            return Position(0.0, 0.0, name, "waypoint")
        return None

    def route_has_waypoint(self, acidx: int, name: str) -> bool:
        return True  # routes are built while simulating; checked then

    def note_reference(self, lat: float, lon: float) -> None:
        pass
