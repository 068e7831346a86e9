"""Bringing aircraft that a resolution turned off their route back to it, and to their destination.

LNAV flies direct to the active waypoint: a turn at the bank angle, then a
straight line. Two geometries make it pass its last waypoint without getting
there, and the autopilot then switches LNAV off and the aircraft flies on along
its track for good (a uam2scn flight is only removed within 0.05 NM of its
destination):

* the point lies inside the turn circle on its side (closer than one turn
  radius to the circle's centre): the turn can never point at it;
* the turn swings the bearing to the point by 90 deg or more from the bearing
  at activation: the autopilot's passing test (BlueSky's: the bearing to the
  waypoint more than 90 deg off the leg's direction) counts it as passed.

An aircraft turned away near its destination and then sent back to its route
meets them (``heading_altitude_sa`` on nyc_eval_678: 65 flights of 678 never
arrived under its ``daa`` baseline, docs/usecases.md; ``RESO DAA`` on
nyc_train_100, seed 1: 8 of 100). :class:`RouteKeeper` sends such an aircraft
back only when it can turn onto its destination (:func:`can_turn_onto`), flying
straight on until then, and sends it back again whenever its route ends (LNAV
off at the last waypoint) before it came within ``arrival_m`` of its
destination. The DAA service (``RESO DAA``) and the use cases that turn
aircraft (``heading_altitude_sa``) keep one each.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from aamsim.hooks import sleep_while_unchanged
from aamsim.units import G0, R_EARTH

if TYPE_CHECKING:
    from aamsim.simapi import SimulationCore

MAX_SWING_DEG = 75.0  # largest swing of the bearing to the point during the turn (the passing test: 90 deg)
TRACK_INTERVAL_S = 1.0  # closest approach to the destination sampled this often (65 m at 126 kt)
ARRIVAL_M = 92.6  # 0.05 NM: uam2scn removes a flight this close to its destination (ATDIST ... 0.05 DEL)


def turn_radius_m(tas_mps: float, gs_mps: float, bank_rad: float) -> float:
    """Radius [m] over the ground of a coordinated turn at ``bank_rad``: turn rate g tan(bank) / TAS [rad/s]."""
    if bank_rad <= 0.0:
        return math.inf
    return gs_mps * max(tas_mps, 1e-3) / (G0 * math.tan(bank_rad))


def can_turn_onto(east_m: float, north_m: float, trk_deg: float, radius_m: float,
                  max_swing_deg: float = MAX_SWING_DEG) -> bool:
    """Whether an aircraft at the origin on track ``trk_deg`` turns onto the point (``east_m``, ``north_m``).

    It turns towards the point's side at ``radius_m`` and then flies straight to
    it. The point is reachable when it lies outside that turn circle and the
    bearing to it swings by less than ``max_swing_deg`` from now to the
    straight leg (the final course is the bearing of the point from the
    circle's centre plus asin(radius / distance) in the turn's direction).
    """
    t = math.radians(trk_deg)
    ahead = east_m * math.sin(t) + north_m * math.cos(t)
    right = east_m * math.cos(t) - north_m * math.sin(t)
    if math.hypot(ahead, right) < 1e-9:
        return True  # already there
    side = 1.0 if right >= 0.0 else -1.0
    from_centre = math.hypot(ahead, right - side * radius_m)
    if from_centre <= radius_m:
        return False
    bearing_now = math.degrees(math.atan2(right, ahead))
    final = math.degrees(math.atan2(right - side * radius_m, ahead) + side * math.asin(radius_m / from_centre))
    swing = abs((final - bearing_now + 180.0) % 360.0 - 180.0)
    return swing < max_swing_deg


def east_north_m(lat0: float, lon0: float, lat1: float, lon1: float) -> tuple[float, float]:
    """East and north offset [m] of point 1 from point 0 (flat earth, local)."""
    dlon = (lon1 - lon0 + 180.0) % 360.0 - 180.0
    return (R_EARTH * math.radians(dlon) * math.cos(math.radians(0.5 * (lat0 + lat1))),
            R_EARTH * math.radians(lat1 - lat0))


@dataclass
class RouteKeeper:
    """Per simulation: the aircraft turned off their route, until they are back at their destination.

    ``steer`` when a use case or a resolution turns an aircraft off its route;
    ``resume`` when it sends it back; ``keep`` at every decision (a use case's
    step, a resolution cycle) for the aircraft it gives no turn now; ``attach``
    to the simulation, under a hook name of the keeper's own.
    """

    arrival_m: float  # an aircraft this close to its destination has arrived [m]
    rejoining: set[str] = field(default_factory=set)  # sent back, flying straight until they can turn
    steered: dict[str, float] = field(default_factory=dict)  # -> closest distance to the destination since [m]
    _hook: Any = field(default=None, repr=False, compare=False)  # the tracking hook (it sleeps while nobody is steered)

    def attach(self, sim: SimulationCore, name: str = "route_keeper.approach") -> None:
        self._hook = sim.hooks.post_step.add(self._track, interval_s=TRACK_INTERVAL_S, name=name)

    def clear(self) -> None:
        """Forget every aircraft (the simulation was reset)."""
        self.rejoining.clear()
        self.steered.clear()

    def forget(self, acid: str) -> None:
        """A new aircraft under a callsign used before."""
        self.rejoining.discard(acid)
        self.steered.pop(acid, None)

    def steer(self, acid: str) -> None:
        """A use case or a resolution turns ``acid`` off its route."""
        self.rejoining.discard(acid)
        self.steered.setdefault(acid, math.inf)

    def can_rejoin(self, sim: SimulationCore, i: int) -> bool:
        """Whether aircraft ``i`` can turn onto its destination (its route's last waypoint) from where it is."""
        view = sim.view
        wps = view.route(i).waypoints
        if not wps:
            return True
        end = wps[-1]
        east, north = east_north_m(float(view.lat[i]), float(view.lon[i]), end.lat, end.lon)
        radius = turn_radius_m(float(view.tas[i]), float(view.gs[i]), float(view.bankdef[i]))
        return can_turn_onto(east, north, float(view.trk[i]), radius)

    def resume(self, sim: SimulationCore, i: int, acid: str, track_deg: float) -> None:
        """Back on the route: LNAV on to its nearest waypoint or, while the aircraft cannot turn onto its
        destination, straight on for now (``rejoining``); without a route, fly ``track_deg``."""
        view = sim.view
        if not len(view.route(i)):
            self.rejoining.discard(acid)
            sim.select_heading(i, track_deg)
        elif self.can_rejoin(sim, i):
            self.rejoining.discard(acid)
            sim.resume_route(i)
        else:
            self.rejoining.add(acid)
            sim.select_heading(i, float(view.trk[i]))

    def keep(self, sim: SimulationCore, turning: set[str]) -> None:
        """At a decision: every aircraft steered before and not ``turning`` now goes back to its destination
        when it waits to rejoin or its route ended (LNAV off at the last waypoint) short of it."""
        view = sim.view
        for acid in sorted(set(self.steered) - turning):
            i = view.find(acid)
            if i is None or self.steered[acid] <= self.arrival_m:  # gone, or arrived: no longer kept
                self.forget(acid)
                continue
            route = view.route(i)
            ended = len(route) > 0 and not view.lnav[i] and route.iactwp == len(route) - 1
            if acid in self.rejoining or ended:
                self.resume(sim, i, acid, float(view.trk[i]))

    def _track(self, sim: SimulationCore) -> None:
        """Closest approach of the steered aircraft to their destinations (a post-step hook)."""
        if not self.steered:
            # Nobody to track: sleep until somebody is steered (awake, each sample ended a batch of steps).
            sleep_while_unchanged(sim.hooks.post_step, self._hook, sim._clock, lambda: bool(self.steered))
            return
        view = sim.view
        for acid, closest in self.steered.items():
            i = view.find(acid)
            wps = view.route(i).waypoints if i is not None else ()
            if wps:
                d = math.hypot(*east_north_m(float(view.lat[i]), float(view.lon[i]), wps[-1].lat, wps[-1].lon))
                if d < closest:
                    self.steered[acid] = d
