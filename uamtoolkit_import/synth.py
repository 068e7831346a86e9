"""A synthetic UAMToolkit: fleet operations over a day, written as a schedule.

The generator replays a day of trip requests (:mod:`uamtoolkit_import.demand`)
against a fleet:

* the fleet of N aircraft starts at midnight spread evenly over the
  vertiports (aircraft k at vertiport k mod V, in network order); each
  aircraft has its own cruise speed, uniform in [87, 150] kt;
* a request is served at once by an idle aircraft at its origin (the one
  idle longest), otherwise it waits in a first-come-first-served queue for
  the next aircraft to become ready there, at most ``max_wait_s``, after
  which it is lost; there is no empty repositioning;
* the flight follows the shortest route through the network, at a lane
  chosen by :class:`~uamtoolkit_import.lanes.LaneBook`; its scheduled
  arrival is the departure plus route length / cruise speed;
* after landing the aircraft needs ``turnaround_s`` before its next flight.

Run ``python -m uamtoolkit_import.synth --help`` (or ``uam2scn synth``).
"""

from __future__ import annotations

import heapq
import logging
import math
from collections import deque
from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np

from aamsim.units import KTS
from uamtoolkit_import.demand import DemandModel, TripRequest, generate_requests
from uamtoolkit_import.lanes import LaneBook, LaneUse, timed_legs
from uamtoolkit_import.network import Network
from uamtoolkit_import.schedule import ScheduledFlight

log = logging.getLogger(__name__)

DAY_S = 86400.0
LANE_RETRY_S = 30.0  # a flight without an acceptable lane tries again this much later [s]


@dataclass(frozen=True)
class SynthConfig:
    """Generator settings (times in s, speeds in kt).

    Attributes:
        fleet_size: number of aircraft.
        seed: seeds demand, speeds and passengers; the same seed gives the same schedule.
        demand: the trip demand model.
        turnaround_s: ground time between two flights of an aircraft.
        max_wait_s: longest a request waits for an aircraft before it is lost.
        max_lane_wait_s: longest a flight is held on the ground for a lane; after
            that it takes the lane with the fewest head-on overlaps.
        speed_range_kts: cruise speeds are uniform in this range (per aircraft).
        day_s: flights depart in [0, day_s).
        aircraft_type: the type written in the schedule (the converter picks the BlueSky type).
        flight_prefix: flight ids are ``<prefix><number>`` in departure order.
    """

    fleet_size: int = 100
    seed: int = 2022
    demand: DemandModel = field(default_factory=DemandModel)
    turnaround_s: float = 600.0
    max_wait_s: float = 900.0
    max_lane_wait_s: float = 600.0
    speed_range_kts: tuple[float, float] = (87.0, 150.0)
    day_s: float = DAY_S
    aircraft_type: str = "EVTOL4"
    flight_prefix: str = "UAM"

    def __post_init__(self) -> None:
        if self.fleet_size < 1:
            raise ValueError("the fleet needs at least one aircraft")
        lo, hi = self.speed_range_kts
        if not 0 < lo <= hi:
            raise ValueError(f"bad cruise speed range {self.speed_range_kts}")
        if self.turnaround_s < 0 or self.max_wait_s < 0 or self.day_s <= 0:
            raise ValueError("turnaround, maximum wait and day length must be non-negative")


@dataclass
class SynthResult:
    """A generated day: its flights (departure order) and how the demand was served."""

    flights: list[ScheduledFlight]
    requests: int
    lost: int
    lane_waits: int
    forced_lanes: int

    @property
    def served(self) -> int:
        return len(self.flights)


@dataclass(frozen=True)
class _Route:
    path: list[str]
    leg_lengths_m: tuple[float, ...]
    lanes_ft: tuple[float, ...]


@dataclass(frozen=True)
class _Flight:
    dep_s: float
    aircraft: int
    request: TripRequest
    path: list[str]
    arr_s: float
    lane_ft: float


@dataclass
class _Aircraft:
    tail: str
    speed_kts: float
    at: str


@dataclass
class _Fleet:
    """Mutable dispatch state of one generation run."""

    network: Network
    config: SynthConfig
    aircraft: list[_Aircraft]
    idle: dict[str, deque[int]]
    waiting: dict[str, deque[TripRequest]]
    lanes: LaneBook = field(default_factory=LaneBook)
    routes: dict[tuple[str, str], _Route] = field(default_factory=dict)
    flights: list[_Flight] = field(default_factory=list)
    lost: int = 0
    lane_waits: int = 0
    forced_lanes: int = 0

    def route(self, origin: str, destination: str) -> _Route:
        key = (origin, destination)
        if key not in self.routes:
            net = self.network
            path = net.shortest_path(origin, destination)
            if path is None:
                raise ValueError(f"no route from {origin} to {destination} in {net.source}")
            legs = tuple(net.leg_length_m(a, b) for a, b in pairwise(path))
            self.routes[key] = _Route(path, legs, net.route_lanes(path))
        return self.routes[key]

    def dispatch(self, req: TripRequest, k: int, t_s: float) -> float | None:
        """Fly request ``req`` with aircraft ``k`` from ``t_s``; returns when it is ready again."""
        route = self.route(req.origin, req.destination)
        self.lanes.forget(t_s)  # events come in time order: no later flight departs before t_s
        ac = self.aircraft[k]
        speed = ac.speed_kts * KTS
        dep = float(math.ceil(t_s))
        latest = dep + self.config.max_lane_wait_s
        while True:
            legs = timed_legs(route.path, route.leg_lengths_m, speed, dep)
            lane = self.lanes.choose(req.origin, req.destination, route.lanes_ft, legs, dep)
            if lane is not None:
                break
            if dep + LANE_RETRY_S > latest:
                lane = self.lanes.least_conflicting(route.lanes_ft, legs, dep)
                self.forced_lanes += 1
                break
            self.lane_waits += 1
            dep += LANE_RETRY_S
        if dep >= self.config.day_s:
            return None
        arr = dep + round(sum(route.leg_lengths_m) / speed)
        self.lanes.occupy(LaneUse(lane, req.origin, req.destination, dep, arr, legs))
        self.flights.append(_Flight(dep, k, req, route.path, arr, lane))
        ac.at = req.destination
        return arr + self.config.turnaround_s


def _initial_fleet(network: Network, config: SynthConfig, rng: np.random.Generator) -> _Fleet:
    ids = list(network.vertiports)
    lo, hi = config.speed_range_kts
    speeds = rng.uniform(lo, hi, size=config.fleet_size)
    width = max(3, len(str(config.fleet_size)))
    aircraft = [
        _Aircraft(f"N{k + 1:0{width}d}", round(float(speeds[k]), 1), ids[k % len(ids)])
        for k in range(config.fleet_size)
    ]
    idle: dict[str, deque[int]] = {v: deque() for v in ids}
    for k, ac in enumerate(aircraft):
        idle[ac.at].append(k)
    return _Fleet(network, config, aircraft, idle, {v: deque() for v in ids},
                  LaneBook(position=network.position))


def synthesize(network: Network, config: SynthConfig | None = None) -> SynthResult:
    """Generate a day of flights (deterministic for a given network and config; None: the defaults)."""
    config = config or SynthConfig()
    rng = np.random.default_rng(config.seed)
    fleet = _initial_fleet(network, config, rng)
    requests = [r for r in generate_requests(network, config.demand, rng) if r.t_s < config.day_s]
    # Events: (time, order, kind, payload); kind 0: aircraft `payload` ready, 1: request `payload` made.
    # Ties in time go by insertion order, so the result does not depend on heap internals.
    events: list[tuple[float, int, int, int]] = [(r.t_s, k, 1, k) for k, r in enumerate(requests)]
    heapq.heapify(events)
    order = len(requests)
    while events:
        t, _, kind, payload = heapq.heappop(events)
        if kind == 1:
            req = requests[payload]
            idle = fleet.idle[req.origin]
            if not idle:
                fleet.waiting[req.origin].append(req)
                continue
            k = idle.popleft()
        else:
            k = payload
            here = fleet.aircraft[k].at
            queue = fleet.waiting[here]
            while queue and queue[0].t_s + config.max_wait_s < t:
                queue.popleft()
                fleet.lost += 1
            if not queue:
                fleet.idle[here].append(k)
                continue
            req = queue.popleft()
        ready = fleet.dispatch(req, k, t)
        if ready is None:  # it could not leave before the end of the day
            fleet.lost += 1
            fleet.idle[fleet.aircraft[k].at].append(k)
            continue
        heapq.heappush(events, (ready, order, 0, k))
        order += 1
    fleet.lost += sum(len(q) for q in fleet.waiting.values())
    flights = _to_schedule(fleet, config)
    log.info(
        "synth: %d requests, %d flights, %d lost, %d lane waits, %d forced lanes",
        len(requests),
        len(flights),
        fleet.lost,
        fleet.lane_waits,
        fleet.forced_lanes,
    )
    return SynthResult(flights, len(requests), fleet.lost, fleet.lane_waits, fleet.forced_lanes)


def _to_schedule(fleet: _Fleet, config: SynthConfig) -> list[ScheduledFlight]:
    ordered = sorted(fleet.flights, key=lambda f: (f.dep_s, f.aircraft))
    width = max(4, len(str(len(ordered))))
    out = []
    for n, fl in enumerate(ordered, start=1):
        fid = f"{config.flight_prefix}{n:0{width}d}"
        req, ac = fl.request, fleet.aircraft[fl.aircraft]
        out.append(
            ScheduledFlight(
                row=n + 1,
                flight_id=fid,
                callsign=fid,
                tail_id=ac.tail,
                aircraft_type=config.aircraft_type,
                origin=req.origin,
                destination=req.destination,
                departure_s=fl.dep_s,
                arrival_s=float(fl.arr_s),
                route=tuple(fl.path[1:-1]),
                cruise_speed_kts=ac.speed_kts,
                cruise_alt_ft=fl.lane_ft,
                passengers=req.passengers,
                cargo_kg=req.cargo_kg,
            )
        )
    return out


if __name__ == "__main__":
    from uamtoolkit_import.cli import synth_command

    synth_command(prog_name="python -m uamtoolkit_import.synth")
