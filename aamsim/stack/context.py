"""Parse contexts: what argument parsers may ask while binding a command.

:class:`LiveContext` answers from a running simulation; :class:`StaticContext`
answers from a scenario file alone (callsigns created by CRE lines, waypoints
defined by DEFWPT lines), for ``--strict`` validation before simulating.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from aamsim.errors import SourceRef, UnknownAircraft
from aamsim.stack.argtypes import Position

if TYPE_CHECKING:
    from aamsim.features import FeatureStates, RunOutputs
    from aamsim.hooks import Hooks
    from aamsim.limits import SimulationLimits
    from aamsim.navdb import NavDatabase
    from aamsim.scenario_files import ScenarioFiles
    from aamsim.services import Services
    from aamsim.settings import SimSettings
    from aamsim.stack.parser import ParsedScenario
    from aamsim.stack.queue import CommandQueue
    from aamsim.stack.registry import CommandRegistry
    from aamsim.traffic.conditions import Conditions
    from aamsim.traffic.route import Route
    from aamsim.traffic.traffic import FlightRecord
    from aamsim.traffic.view import TrafficView
    from aamsim.units import Speed


@dataclass
class LiveContext:
    sim: CommandContext
    last_acidx: int = -1
    ref_lat: float = 0.0
    ref_lon: float = 0.0

    def aircraft_index(self, acid: str) -> int:
        view = self.sim.view
        i = view.slot(acid)
        self.ref_lat = float(view.lat[i])
        self.ref_lon = float(view.lon[i])
        return i

    def named_position(self, name: str) -> Position | None:
        view = self.sim.view
        i = view.find(name)
        if i is not None:
            return Position(float(view.lat[i]), float(view.lon[i]), name, "aircraft")
        runway = self.sim.navdb.runway(name)
        if runway is not None:
            return Position(runway[0], runway[1], name, "runway", runway[2])
        found = self.sim.navdb.lookup(name, self.ref_lat, self.ref_lon)
        if found is None:
            return None
        return Position(found[0], found[1], name, "waypoint")

    def is_airport(self, name: str) -> bool:
        return self.sim.navdb.is_airport(name)

    def route_has_waypoint(self, acidx: int, name: str) -> bool:
        if acidx < 0:
            return False
        return self.sim.view.route(acidx).find(name) >= 0

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

    def is_airport(self, name: str) -> bool:
        """Whether ``name`` is an airport (so that ``EHAM RW18C`` reads as one runway position)."""
        navdb = getattr(self.navdb_known, "__self__", None)  # navdb_known is a NavDatabase's bound known()
        return bool(navdb is not None and getattr(navdb, "is_airport", None) and navdb.is_airport(name))

    def note_reference(self, lat: float, lon: float) -> None:
        pass


@runtime_checkable
class CommandContext(Protocol):
    """What a command handler receives: the simulation as the stack sees it.

    Handlers read the traffic through ``view`` (named arrays, SI units) and change
    it through the intent methods of :mod:`aamsim.api`; they never see the field
    matrices, the kernel or the stepping loop. :class:`aamsim.Simulation`
    implements this protocol; another backend (BlueSky, through the bridge) could.
    """

    STATE_INIT: str
    STATE_OP: str
    STATE_HOLD: str
    state: str
    quit_requested: bool
    seed: int | None
    settings: SimSettings
    commands: CommandRegistry
    files: ScenarioFiles
    limits: SimulationLimits
    navdb: NavDatabase
    conditions: Conditions
    hooks: Hooks
    plugins: dict[str, Any]
    features: FeatureStates  # per-simulation state of optional features, by class
    run_outputs: RunOutputs
    pending_work: list[Callable[[], bool]]
    services: Services

    # clock, randomness and messages
    @property
    def simt(self) -> float: ...
    @property
    def dt(self) -> float: ...
    @property
    def rng(self) -> np.random.Generator: ...
    @property
    def current_source(self) -> SourceRef | None: ...
    def set_dt(self, dt_s: float) -> None: ...
    def reseed(self, seed: int | None) -> None: ...
    def report(self, kind: str, text: str, source: SourceRef | None = None) -> None: ...
    def note_once(self, key: str, text: str, source: SourceRef | None = None) -> None: ...

    # commands and scenario files
    @property
    def queue(self) -> CommandQueue: ...
    def stack(self, text: str, source: SourceRef | None = None) -> bool: ...
    def schedule(self, time_s: float, text: str, source: SourceRef | None = None) -> None: ...
    def parse(self, text: str, path: str = "<scenario>", **kwargs: Any) -> ParsedScenario: ...
    def load_scenario(self, path: str | Path, *, text: str | None = None) -> ParsedScenario: ...
    def find_file(self, name: str) -> Path | None: ...
    def reset(self) -> None: ...

    # the traffic: read through the view, changed through intents (aamsim.api)
    @property
    def view(self) -> TrafficView: ...
    def slot(self, acid: str | int) -> int: ...
    def edit_route(self, slot: int) -> Route: ...
    def activate_waypoint(self, slot: int, index: int) -> None: ...
    def flight_record(self, slot: int) -> FlightRecord: ...
    def create_aircraft(self, acid: str, actype: str, lat: float, lon: float, hdg: float = 0.0,
                        alt: float = 0.0, spd: Speed | None = None, noncooperative: bool = False) -> int: ...
    def set_replay_state(self, targets: Any, lat: np.ndarray, lon: np.ndarray, alt_m: np.ndarray,
                         gsnorth_mps: np.ndarray, gseast_mps: np.ndarray, vs_mps: np.ndarray) -> None: ...
    def delete_aircraft(self, i: int, arrived: bool | None = None) -> FlightRecord: ...
    def select_speed(self, targets: Any, speed: Speed | float | np.ndarray) -> None: ...
    def select_altitude(self, target: str | int, altitude_m: float, vs_mps: float | None = None) -> None: ...
    def select_vertical_speed(self, target: str | int, vs_mps: float) -> None: ...
    def select_heading(self, target: str | int, heading_deg: float) -> None: ...
    def set_bank(self, target: str | int, bank_rad: float) -> None: ...
    def set_cruise_speed(self, target: str | int, cas_mps: float) -> None: ...
    def move(self, target: str | int, lat: float, lon: float, alt_m: float | None = None,
             hdg_deg: float | None = None, speed: Speed | None = None, vs_mps: float | None = None) -> None: ...
    def displace(self, targets: Any, dnorth_m: np.ndarray, deast_m: np.ndarray, dalt_m: np.ndarray) -> None: ...
    def direct_to(self, target: str | int, waypoint: str | int) -> None: ...
    def set_navigation(self, target: str | int, lnav: bool | None = None, vnav: bool | None = None,
                       vnav_speed: bool | None = None) -> None: ...
    def resume_route(self, target: str | int) -> None: ...
    def engage_vnav(self, target: str | int) -> None: ...
    def set_climb_profile(self, target: str | int, early_climb: bool | None = None,
                          late_descent: bool | None = None) -> None: ...

    # the wind field (WIND, GETWIND, DEL WIND)
    def wind_at(self, lat: float, lon: float, alt_m: float) -> tuple[float, float]: ...
    def add_wind_point(self, lat: float, lon: float, direction_deg: float, speed_mps: float) -> None: ...
    def add_wind_profile(self, lat: float, lon: float, alts_m: np.ndarray, directions_deg: np.ndarray,
                         speeds_mps: np.ndarray) -> None: ...
    def clear_wind(self) -> None: ...
