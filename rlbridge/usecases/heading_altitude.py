"""Tactical deconfliction of eVTOLs between vertiports by heading and altitude advisories.

Every airborne aircraft is an agent (as in the corridor use case) and flies
its route between vertiports at its own speed. Every ``decision_interval_s``
it observes its deviation from its route and its own altitude and its closest
intruders, and picks one advisory, a pair (heading offset, altitude offset):

* heading: fly ``heading_offsets_deg[h]`` off the bearing to the active waypoint
  (LNAV off); offset 0 resumes the route (LNAV on, to the nearest waypoint). An
  aircraft that cannot turn onto its destination from where it is (inside its
  turn circle, :mod:`aamsim.resolution.rejoin`) flies straight on instead and
  resumes at the first decision it can: flown at once, LNAV would pass the
  destination, switch off and leave the aircraft flying on for good;
* altitude: fly ``altitude_offsets_ft[z]`` off the aircraft's own altitude (the one
  the scenario selects; at ``climb_rate_fpm``, never below ``alt_floor_ft``); offset
  0 returns to it.

Action ``h * len(altitude_offsets_ft) + z``; the action of offsets (0, 0) is
**resume** (no advisory). The design follows the heading and altitude
conflict-resolution environments built on BlueSky (bluesky-gym's horizontal and
vertical conflict resolution; Groot et al., "Improving safety of vertical
manoeuvres in a layered airspace with deep reinforcement learning", 2021):
resolution by heading and level changes, a penalty for intrusions and one for
leaving the planned path, here with the paper's (AAM-Gym) separation reward.

Reward per agent and decision: ``R(s, h)`` of the corridor use case (-1 inside
NMAC during the interval, ``-alpha + delta d`` for the closest intruder within
``d_max``), ``-psi`` for an advisory (any action but resume), minus
``xtrack_cost_per_km`` per km off the route leg and ``alt_cost_per_100m`` per
100 m off the own altitude, minus ``omega``. Per-agent info: ``nmac``, ``lowc``
(events during the interval), ``xtrack_m``, ``dalt_m``. Episode variation:
the paper's altitude noise (+-100 ft about the lanes, from the reset seed);
``fixed_traffic`` switches it off. docs/usecases.md documents observation,
reward and metrics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import gymnasium as gym
import numpy as np

from aamsim.conflicts import pairs_within
from aamsim.metrics import record_advisory
from aamsim.resolution.rejoin import RouteKeeper, east_north_m
from aamsim.units import FPM, FT, R_EARTH
from rlbridge.observe import nearest_neighbours
from rlbridge.usecases.protocol import Feedback, Observations, UseCaseBase, make_params
from rlbridge.usecases.separation import apply_separation, check_distances, nmac_distance
from rlbridge.usecases.spec import SEPARATION_CURVE, CurveColumn, UseCaseSpec
from rlbridge.usecases.variation import NYC_LANES_FT, PAPER_ALT_NOISE_FT, add_altitude_noise

if TYPE_CHECKING:
    from aamsim import Simulation

OWN_DIM, INTRUDER_DIM = 8, 7


@dataclass(frozen=True)
class HeadingAltitudeParams:
    """Use-case parameters (distances m, times s; the offsets in deg and ft)."""

    nmac_m: float | None = None  # None: the simulation's separation standard (rlbridge.usecases.separation)
    lowc_m: float | None = None  # None: the simulation's separation standard
    d_max_m: float = 3000.0  # the separation reward acts within this distance
    alpha: float = 1.0
    delta: float = 0.0003
    nmac_penalty: float = 1.0
    psi: float = 0.001  # per advisory (any action but resume)
    omega: float = 0.001  # per decision
    xtrack_cost_per_km: float = 0.02  # per km off the route leg
    alt_cost_per_100m: float = 0.02  # per 100 m off the own altitude
    heading_offsets_deg: tuple[float, ...] = (-40.0, -20.0, 0.0, 20.0, 40.0)
    altitude_offsets_ft: tuple[float, ...] = (-500.0, 0.0, 500.0)  # 500 ft: above the NMAC distance (150 m)
    climb_rate_fpm: float = 1000.0
    alt_floor_ft: float = 300.0
    # An aircraft turned off its route is back at its destination this close to it (uam2scn removes a flight
    # within 0.05 NM); until then the use case sends it back whenever its route ends (aamsim.resolution.rejoin).
    arrival_m: float = 92.6
    decision_interval_s: float = 10.0
    n_intruders: int = 10
    intruder_range_m: float = 5000.0
    obs_format: str = "flat"  # "flat" or "dict" (ownship, intruders, mask) for attention models
    reward_interval_nmac: bool = True  # an NMAC during the interval counts even if over by the decision
    # The paper's altitude noise, drawn per episode seed at creation (rlbridge.usecases.variation).
    alt_noise_ft: float = PAPER_ALT_NOISE_FT
    alt_noise_lanes_ft: tuple[float, ...] = NYC_LANES_FT
    # Feature scales (divisors).
    scale_pos_m: float = 5000.0
    scale_xtrack_m: float = 1000.0
    scale_dalt_m: float = 100.0
    scale_spd_mps: float = 100.0
    scale_vs_mps: float = 5.0
    scale_dist_m: float = 10000.0

    def __post_init__(self) -> None:
        for name in ("heading_offsets_deg", "altitude_offsets_ft", "alt_noise_lanes_ft"):
            object.__setattr__(self, name, tuple(float(x) for x in getattr(self, name)))
        for name in ("heading_offsets_deg", "altitude_offsets_ft"):
            offsets = getattr(self, name)
            if 0.0 not in offsets or len(set(offsets)) != len(offsets):
                raise ValueError(f"{name} must hold 0 (resume) and no value twice, not {offsets}")
        if any(abs(h) >= 180.0 for h in self.heading_offsets_deg):
            raise ValueError("heading_offsets_deg must lie strictly between -180 and 180")
        if self.obs_format not in ("flat", "dict"):
            raise ValueError(f"obs_format must be 'flat' or 'dict', not {self.obs_format!r}")
        check_distances(self, "nmac_m", "lowc_m")
        for name in ("d_max_m", "decision_interval_s", "intruder_range_m", "climb_rate_fpm",
                     "arrival_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive")
        if self.n_intruders < 1:
            raise ValueError("n_intruders must be at least 1")


@dataclass
class _Episode:
    """Per-episode state: each agent's own altitude, route-leg start and advisories in force."""

    own_alt: dict[str, float]
    leg_start: dict[str, tuple[float, float]]
    own_trk: dict[str, float]
    off_route: set[str]
    off_level: set[str]
    last_action: dict[str, int]
    keeper: RouteKeeper  # brings the aircraft turned off their route back to it and to their destination
    heading_advisories: int = 0
    altitude_advisories: int = 0
    decisions: int = 0
    sum_xtrack: float = 0.0
    max_xtrack: float = 0.0
    sum_dalt: float = 0.0


class HeadingAltitudeSA(UseCaseBase):
    """``heading_altitude_sa`` (``aamgym/HeadingAltitudeSA-v1``): see the module docstring."""

    name = "heading_altitude_sa"
    env_name = "HeadingAltitudeSA"
    # An action other than resume that differs from the aircraft's previous one is an advisory.
    spec = UseCaseSpec(HeadingAltitudeParams, action_kinds=("heading", "altitude"), baselines=("daa", "mvp"),
                       advisory="manoeuvre_change",
                       metrics=("heading_advisories", "altitude_advisories", "mean_abs_xtrack_m",
                                "max_abs_xtrack_m", "mean_abs_dalt_m"),
                       curve=(*SEPARATION_CURVE,
                              CurveColumn("mean_abs_xtrack_m", "heading_altitude_sa.mean_abs_xtrack_m",
                                          per_aircraft=False)))
    fixed_traffic: ClassVar[dict[str, Any]] = {"alt_noise_ft": 0.0}
    conflicts_of_agents_only: ClassVar[bool] = True  # feedback: involved_since of its agents
    info_fields = {"nmac": np.bool_, "lowc": np.bool_, "xtrack_m": np.float64, "dalt_m": np.float64}  # noqa: RUF012

    def __init__(self, **params: Any):
        self.params: HeadingAltitudeParams = make_params(HeadingAltitudeParams, params)
        p = self.params
        self.n_alt = len(p.altitude_offsets_ft)
        self.n_actions = len(p.heading_offsets_deg) * self.n_alt
        self.resume_action = p.heading_offsets_deg.index(0.0) * self.n_alt + p.altitude_offsets_ft.index(0.0)
        self.climb_rate_mps = p.climb_rate_fpm * FPM  # vertical speed of the altitude advisories
        self.own_dim, self.intruder_dim = OWN_DIM, INTRUDER_DIM
        big = np.float32(1e6)
        if p.obs_format == "flat":
            dim = OWN_DIM + p.n_intruders * (INTRUDER_DIM + 1)
            self._obs_space: gym.Space = gym.spaces.Box(-big, big, shape=(dim,), dtype=np.float32)
        else:
            self._obs_space = gym.spaces.Dict({
                "ownship": gym.spaces.Box(-big, big, shape=(OWN_DIM,), dtype=np.float32),
                "intruders": gym.spaces.Box(-big, big, shape=(p.n_intruders, INTRUDER_DIM), dtype=np.float32),
                "mask": gym.spaces.Box(0.0, 1.0, shape=(p.n_intruders,), dtype=np.float32)})
        self._act_space: gym.spaces.Discrete = gym.spaces.Discrete(self.n_actions)
        self.ep = _Episode({}, {}, {}, set(), set(), {}, RouteKeeper(p.arrival_m))

    @property
    def decision_interval_s(self) -> float:
        return self.params.decision_interval_s

    def observation_space(self) -> gym.Space:
        return self._obs_space

    def action_space(self) -> gym.Space:
        return self._act_space

    def offsets(self, action: int) -> tuple[float, float]:
        """The (heading [deg], altitude [ft]) offsets of an action."""
        h, z = divmod(int(action), self.n_alt)
        return self.params.heading_offsets_deg[h], self.params.altitude_offsets_ft[z]

    # -------------------------------------------------------------- lifecycle
    def attach(self, sim: Simulation) -> None:
        p = self.params
        apply_separation(sim, p.nmac_m, p.lowc_m)
        self.ep = _Episode({}, {}, {}, set(), set(), {}, RouteKeeper(p.arrival_m))
        add_altitude_noise(sim, p.alt_noise_ft, p.alt_noise_lanes_ft, "heading_altitude.alt_noise")
        sim.hooks.created.add(self._on_created, name="heading_altitude.created")
        self.ep.keeper.attach(sim)

    def _on_created(self, sim: Simulation, slot: int) -> None:
        view = sim.view
        acid = view.ids[slot]
        self.ep.leg_start[acid] = (float(view.lat[slot]), float(view.lon[slot]))
        self.ep.off_route.discard(acid)
        self.ep.off_level.discard(acid)
        self.ep.keeper.forget(acid)
        self.ep.last_action.pop(acid, None)

    # -------------------------------------------------------------- geometry
    def _route_geometry(self, sim: Simulation, slots: np.ndarray) -> tuple[np.ndarray, ...]:
        """Per slot: bearing to the active waypoint [deg], cross-track offset from the route leg
        [m, right of the leg positive], distance to the destination [m], own altitude [m]."""
        view = sim.view
        n = len(slots)
        bearing, xtrack, ddest, own = (np.zeros(n) for _ in range(4))
        for k, i in enumerate(np.asarray(slots, dtype=np.int64).tolist()):
            acid = view.ids[i]
            lat, lon = float(view.lat[i]), float(view.lon[i])
            own[k] = self.ep.own_alt.setdefault(acid, float(view.selalt[i]))
            route = view.route(i)
            wps = route.waypoints
            if not wps or not 0 <= route.iactwp < len(wps):
                bearing[k] = self.ep.own_trk.get(acid, float(view.trk[i]))
                continue
            b = wps[route.iactwp]
            a = (wps[route.iactwp - 1].lat, wps[route.iactwp - 1].lon) if route.iactwp > 0 else \
                self.ep.leg_start.get(acid, (lat, lon))
            ax, ay = east_north_m(lat, lon, a[0], a[1])
            bx, by = east_north_m(lat, lon, b.lat, b.lon)
            bearing[k] = math.degrees(math.atan2(bx, by)) % 360.0
            leg = math.hypot(bx - ax, by - ay)
            xtrack[k] = ((by - ay) * -ax - (bx - ax) * -ay) / leg if leg > 1.0 else 0.0
            end = wps[-1]
            rec = view.flight(i)
            dlat, dlon = (rec.dest_lat, rec.dest_lon) if not math.isnan(rec.dest_lat) else (end.lat, end.lon)
            ddest[k] = math.hypot(*east_north_m(lat, lon, dlat, dlon))
        return bearing, xtrack, ddest, own

    # ------------------------------------------------------------ observation
    def observe(self, sim: Simulation, agents: list[str]) -> Observations:
        p = self.params
        view = sim.view
        slots = sim.slots(agents) if agents else np.empty(0, dtype=np.int64)
        bearing, xtrack, ddest, own_alt = self._route_geometry(sim, slots)
        nbr, nbr_d = self._neighbours(sim, slots)
        trk = np.radians(np.asarray(view.trk, dtype=np.float64))
        own = np.zeros((len(slots), OWN_DIM), dtype=np.float32)
        rel = np.radians(bearing) - trk[slots]
        ep = self.ep
        advised = np.array([a in ep.off_route or a in ep.off_level or a in ep.keeper.rejoining for a in agents],
                           dtype=np.float32)
        own[:, 0] = xtrack / p.scale_xtrack_m
        own[:, 1], own[:, 2] = np.sin(rel), np.cos(rel)
        own[:, 3] = ddest / p.scale_dist_m
        own[:, 4] = (view.alt[slots] - own_alt) / p.scale_dalt_m
        own[:, 5] = view.vs[slots] / p.scale_vs_mps
        own[:, 6] = view.gs[slots] / p.scale_spd_mps
        own[:, 7] = advised
        intr = np.zeros((len(slots), p.n_intruders, INTRUDER_DIM), dtype=np.float32)
        mask = (nbr >= 0).astype(np.float32)
        q, k = np.nonzero(nbr >= 0)
        if q.size:
            o, j = slots[q], nbr[q, k]
            lat0 = np.radians(view.lat[o])
            dx = R_EARTH * np.radians((view.lon[j] - view.lon[o] + 180.0) % 360.0 - 180.0) * np.cos(lat0)
            dy = R_EARTH * np.radians(view.lat[j] - view.lat[o])
            du, dv = view.gseast[j] - view.gseast[o], view.gsnorth[j] - view.gsnorth[o]
            s, c = np.sin(trk[o]), np.cos(trk[o])
            intr[q, k, 0] = (dx * s + dy * c) / p.scale_pos_m  # along the ownship's track
            intr[q, k, 1] = (dx * c - dy * s) / p.scale_pos_m  # right of it
            intr[q, k, 2] = (view.alt[j] - view.alt[o]) / p.scale_dalt_m
            intr[q, k, 3] = (du * s + dv * c) / p.scale_spd_mps
            intr[q, k, 4] = (du * c - dv * s) / p.scale_spd_mps
            intr[q, k, 5] = (view.vs[j] - view.vs[o]) / p.scale_vs_mps
            intr[q, k, 6] = nbr_d[q, k] / p.scale_pos_m
        if p.obs_format == "dict":
            return Observations(parts={"ownship": own, "intruders": intr, "mask": mask})
        flat = np.concatenate([own, intr.reshape(len(slots), -1), mask], axis=1)
        return Observations(flat=flat)

    def _neighbours(self, sim: Simulation, slots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = self.params
        rng = max(p.intruder_range_m, p.d_max_m)
        pi, pj, d = pairs_within(sim, rng)
        return nearest_neighbours(sim.view.n, np.asarray(slots, dtype=np.int64), pi, pj, d, p.n_intruders, rng)

    # ----------------------------------------------------------------- action
    def heading_action_targets(self, sim: Simulation, slots: np.ndarray) -> np.ndarray:
        """Track [deg] each action flies per aircraft (the resume actions: the bearing to the active waypoint,
        or the track it has for an aircraft off its route that cannot turn onto its destination yet)."""
        bearing, _, _, _ = self._route_geometry(sim, slots)
        off = np.array([self.offsets(a)[0] for a in range(self.n_actions)])
        out = (bearing[:, None] + off[None, :]) % 360.0
        view, keeper = sim.view, self.ep.keeper
        for k, i in enumerate(np.asarray(slots, dtype=np.int64).tolist()):
            if view.ids[i] in keeper.steered and not view.lnav[i] and not keeper.can_rejoin(sim, i):
                out[k, off == 0.0] = float(view.trk[i])  # it flies straight on until it can (RouteKeeper)
        return out

    def altitude_action_targets(self, sim: Simulation, slots: np.ndarray) -> np.ndarray:
        """Altitude [m] each action flies to per aircraft (its own altitude plus the offset, above the floor)."""
        _, _, _, own = self._route_geometry(sim, slots)
        off = np.array([self.offsets(a)[1] for a in range(self.n_actions)]) * FT
        return np.maximum(own[:, None] + off[None, :], self.params.alt_floor_ft * FT)

    def idle_decisions_change_nothing(self, sim: Simulation) -> bool:
        # Without actions the keeper puts the aircraft it steers back on their routes; it steers
        # nobody until an action turns one off its route.
        return not self.ep.keeper.steered

    def apply_actions(self, sim: Simulation, actions: dict[str, Any]) -> None:
        """Heading and altitude advisories (missing agents: no advisory). All are checked before any is applied."""
        view = sim.view
        todo: list[tuple[str, int, int]] = []
        for acid, action in actions.items():
            i = view.find(acid)
            if i is None:
                continue
            a = int(action)
            if not 0 <= a < self.n_actions:
                raise ValueError(f"action {action!r} for {acid} is not in 0..{self.n_actions - 1}")
            todo.append((acid, i, a))
        ep, rate = self.ep, self.params.climb_rate_fpm * FPM
        if not todo:
            ep.keeper.keep(sim, ep.off_route)
            return
        slots = np.array([i for _, i, _ in todo], dtype=np.int64)
        trk = self.heading_action_targets(sim, slots)
        alt = self.altitude_action_targets(sim, slots)
        resumed: set[str] = set()
        for k, (acid, i, a) in enumerate(todo):
            dh, dz = self.offsets(a)
            if dh != 0.0:
                if acid not in ep.off_route:
                    ep.own_trk[acid] = float(view.trk[i])
                    ep.off_route.add(acid)
                ep.keeper.steer(acid)
                sim.select_heading(i, float(trk[k, a]))
            elif acid in ep.off_route:  # back on the route (or the track it had)
                ep.off_route.discard(acid)
                ep.keeper.resume(sim, i, acid, ep.own_trk.get(acid, float(view.trk[i])))
                resumed.add(acid)
            if dz != 0.0 or acid in ep.off_level:
                target = float(alt[k, a])
                if abs(float(view.selalt[i]) - target) > 0.01:
                    sim.select_altitude(i, target, rate if target > view.alt[i] else -rate)
                if dz != 0.0:
                    ep.off_level.add(acid)
                else:
                    ep.off_level.discard(acid)
            else:  # not advised: the scenario's own altitude is the reference
                ep.own_alt[acid] = float(view.selalt[i])
            if a != self.resume_action and ep.last_action.get(acid) != a:
                kinds = [name for name, off in (("heading", dh), ("altitude", dz)) if off != 0.0]
                record_advisory(sim, acid, "+".join(kinds))
                ep.heading_advisories += dh != 0.0
                ep.altitude_advisories += dz != 0.0
            ep.last_action[acid] = a
        ep.keeper.keep(sim, ep.off_route | resumed)

    # ----------------------------------------------------------------- reward
    def feedback(self, sim: Simulation, agents: list[str], actions: dict[str, Any], since_s: float) -> Feedback:
        p = self.params
        service = sim.services.conflicts
        nmac_min = service.involved_since("nmac", since_s)
        lowc = service.involved_since("lowc", since_s)
        slots = sim.slots(agents) if agents else np.empty(0, dtype=np.int64)
        _, xtrack, _, own = self._route_geometry(sim, slots)
        _, nbr_d = self._neighbours(sim, slots)
        d = nbr_d[:, 0].copy() if len(slots) else np.empty(0)
        if p.reward_interval_nmac:
            for k, a in enumerate(agents):
                if a in nmac_min:
                    d[k] = min(d[k], nmac_min[a])
        dalt = np.asarray(sim.view.alt[slots], dtype=np.float64) - own
        r_sh = np.where(d < nmac_distance(sim), -p.nmac_penalty, np.where(d < p.d_max_m, -p.alpha + p.delta * d, 0.0))
        r_a = np.array([0.0 if int(actions.get(a, self.resume_action)) == self.resume_action else -p.psi
                        for a in agents])
        rewards = r_sh + r_a - p.xtrack_cost_per_km * np.abs(xtrack) / 1000.0 \
            - p.alt_cost_per_100m * np.abs(dalt) / 100.0 - p.omega
        ep = self.ep
        ep.decisions += len(agents)
        ep.sum_xtrack += float(np.abs(xtrack).sum())
        ep.max_xtrack = max(ep.max_xtrack, float(np.abs(xtrack).max(initial=0.0)))
        ep.sum_dalt += float(np.abs(dalt).sum())
        info = {"nmac": np.array([a in nmac_min for a in agents], dtype=np.bool_),
                "lowc": np.array([a in lowc for a in agents], dtype=np.bool_),
                "xtrack_m": xtrack.astype(np.float64), "dalt_m": dalt}
        return Feedback(rewards.astype(np.float64), info)

    def extra_metrics(self, sim: Simulation) -> dict[str, Any]:
        ep = self.ep
        n = max(ep.decisions, 1)
        return {"heading_advisories": ep.heading_advisories, "altitude_advisories": ep.altitude_advisories,
                "mean_abs_xtrack_m": ep.sum_xtrack / n, "max_abs_xtrack_m": ep.max_xtrack,
                "mean_abs_dalt_m": ep.sum_dalt / n}

