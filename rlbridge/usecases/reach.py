"""Reach the destination: a small second use case (the worked example of docs/usecases.md).

Every aircraft is an agent. At each decision it observes its distance to its
destination, its speed and the bearing to the destination relative to its
track, and picks one of ``speeds_kts`` (CAS). Reward: ``-time_penalty`` per
second of the interval, plus ``arrival_bonus`` when it arrives (its aircraft
is deleted within the arrival radius of its destination). Per-agent info:
``arrived`` (bool) and ``dist_m`` (float, distance to the destination).

It uses nothing but the simulator API (``sim.view``, ``sim.select_speed``) and
the use-case protocol.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import gymnasium as gym
import numpy as np

from aamsim.metrics import record_advisory
from aamsim.units import KTS
from aamsim.units import R_EARTH as R_EARTH_M
from rlbridge.usecases.protocol import Feedback, Observations, UseCaseBase, make_params, start_overlay
from rlbridge.usecases.spec import SEPARATION_CURVE, SPEED_TARGETS, CurveColumn, UseCaseSpec
from rlbridge.usecases.variation import PAPER_CRUISE_KTS, check_range, draw_cruise_speed

if TYPE_CHECKING:
    from aamsim import Simulation


@dataclass(frozen=True)
class ReachParams:
    speeds_kts: tuple[float, ...] = (30.0, 60.0, 90.0)
    time_penalty: float = 0.001  # per second
    arrival_bonus: float = 1.0
    decision_interval_s: float = 10.0
    scale_dist_m: float = 10000.0
    scale_spd_mps: float = 50.0
    # The paper's cruising speeds (uniform 87..150 kt per vehicle), drawn per episode seed at creation
    # (rlbridge.usecases.variation): each aircraft flies its draw until its first decision. () keeps the
    # scenario's speeds.
    cruise_speed_kts: tuple[float, ...] = PAPER_CRUISE_KTS
    # Real traffic as non-cooperative intruders (docs/real-traffic.md), as in corridor_sa.
    overlay: str = ""
    overlay_offset: str = ""
    overlay_area: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "overlay_area", tuple(float(x) for x in self.overlay_area))
        object.__setattr__(self, "cruise_speed_kts", check_range("cruise_speed_kts", self.cruise_speed_kts))
        if len(self.overlay_area) not in (0, 4):
            raise ValueError("overlay_area is 4 numbers LAT0, LON0, LAT1, LON1 (or empty)")
        if not self.speeds_kts or min(self.speeds_kts) < 0:
            raise ValueError("speeds_kts must list at least one speed >= 0")
        if not self.decision_interval_s > 0:
            raise ValueError("decision_interval_s must be positive")


class ReachDestination(UseCaseBase):
    """``reach_destination`` (``aamgym/ReachDestination-v1``)."""

    name = "reach_destination"
    env_name = "ReachDestination"
    # Each action selects one of speeds_kts. The rule-based baselines that fit: DAA steers with
    # speed_action_targets (these speeds); the speed-only MVP needs decelerate/hold/accelerate actions
    # (its "hold" would select 60 kt here) and is refused. An action that changes the selected speed is
    # an advisory.
    spec = UseCaseSpec(ReachParams, action_kinds=("speed",), speed_actions=SPEED_TARGETS, baselines=("daa",),
                       advisory="target_change", metrics=("arrivals", "flights_ended"),
                       curve=(CurveColumn("arrivals_per_aircraft", "reach_destination.arrivals"),
                              CurveColumn("episode_arrivals_per_aircraft", "reach_destination.arrivals",
                                          each_episode=True),
                              *SEPARATION_CURVE[:2]))
    fixed_traffic: ClassVar[dict[str, Any]] = {"cruise_speed_kts": ()}
    conflicts_of_agents_only: ClassVar[bool] = True  # reads no separation events at all
    info_fields = {"arrived": np.bool_, "dist_m": np.float64}  # noqa: RUF012

    def __init__(self, **params: Any):
        if "speeds_kts" in params:
            params["speeds_kts"] = tuple(float(x) for x in params["speeds_kts"])
        self.params: ReachParams = make_params(ReachParams, params)
        big = np.float32(1e6)
        self._obs_space = gym.spaces.Box(-big, big, shape=(4,), dtype=np.float32)
        self._act_space: gym.spaces.Discrete = gym.spaces.Discrete(len(self.params.speeds_kts))

    @property
    def decision_interval_s(self) -> float:
        return self.params.decision_interval_s

    def attach(self, sim: Simulation) -> None:
        p = self.params
        draw_cruise_speed(sim, p.cruise_speed_kts, "reach.cruise_speed")
        start_overlay(sim, p.overlay, p.overlay_offset, p.overlay_area)

    def observation_space(self) -> gym.Space:
        return self._obs_space

    def action_space(self) -> gym.Space:
        return self._act_space

    def _destination(self, sim: Simulation, slot: int) -> tuple[float, float]:
        view = sim.view
        rec = view.flight(slot)
        if not math.isnan(rec.dest_lat):
            return rec.dest_lat, rec.dest_lon
        route = view.route(slot)
        if len(route):
            last = route.waypoints[-1]
            return last.lat, last.lon
        return float(view.lat[slot]), float(view.lon[slot])  # no destination: already there

    def _geometry(self, sim: Simulation, agents: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance [m] and bearing [deg] to the destination, and the slots, of each agent."""
        slots = sim.slots(agents)
        view = sim.view
        dest = np.array([self._destination(sim, int(s)) for s in slots]).reshape(len(slots), 2)
        lat, lon = view.lat[slots], view.lon[slots]
        dlat = np.radians(dest[:, 0] - lat)
        dlon = np.radians((dest[:, 1] - lon + 180.0) % 360.0 - 180.0) * np.cos(np.radians(lat))
        return R_EARTH_M * np.hypot(dlat, dlon), np.degrees(np.arctan2(dlon, dlat)), slots

    def observe(self, sim: Simulation, agents: list[str]) -> Observations:
        dist, bearing, slots = self._geometry(sim, agents)
        view = sim.view
        rel = np.radians(bearing - view.trk[slots])
        p = self.params
        flat = np.stack([dist / p.scale_dist_m, view.cas[slots] / p.scale_spd_mps, np.sin(rel), np.cos(rel)],
                        axis=1).astype(np.float32)
        return Observations(flat=flat)

    def speed_action_targets(self, sim: Simulation, slots: np.ndarray) -> np.ndarray:
        """CAS [m/s] each action selects (the same speeds for every aircraft)."""
        return np.tile(np.asarray(self.params.speeds_kts, dtype=np.float64) * KTS, (len(slots), 1))

    def idle_decisions_change_nothing(self, sim: Simulation) -> bool:
        return True  # apply_actions({}) returns at once

    def apply_actions(self, sim: Simulation, actions: dict[str, Any]) -> None:
        agents = [a for a in actions if a in sim.view]
        codes = [int(actions[a]) for a in agents]
        bad = [c for c in codes if not 0 <= c < len(self.params.speeds_kts)]
        if bad:
            raise ValueError(f"action {bad[0]} is not in 0..{len(self.params.speeds_kts) - 1}")
        if not agents:
            return
        targets = np.array([self.params.speeds_kts[c] * KTS for c in codes])
        # An advisory is an action that changes the aircraft's selected speed (repeating it is no alert).
        before = sim.view.selspd[sim.slots(agents)]
        sim.select_speed(agents, targets)
        for a, old_mps, new_mps in zip(agents, before, targets):
            if not abs(old_mps - new_mps) < 1e-6:
                record_advisory(sim, a, f"speed {new_mps / KTS:.0f} kt")

    def feedback(self, sim: Simulation, agents: list[str], actions: dict[str, Any], since_s: float) -> Feedback:
        dist, _, _ = self._geometry(sim, agents)
        # An agent being deleted within the arrival radius arrives (the simulation's own rule).
        arrived = dist <= sim.settings.arrival_radius_m
        p = self.params
        rewards = -p.time_penalty * (sim.simt - since_s) + np.where(arrived, p.arrival_bonus, 0.0)
        return Feedback(rewards.astype(np.float64), {"arrived": arrived.astype(np.bool_), "dist_m": dist})

    def extra_metrics(self, sim: Simulation) -> dict[str, Any]:
        done = [r for r in sim.flight_log if not r.real_traffic]
        return {"arrivals": sum(r.arrived for r in done), "flights_ended": len(done)}
