"""Separation assurance in AAM corridors (the AAM-Gym paper's use case).

Every airborne aircraft is an agent. Every ``decision_interval_s`` it observes
its own state and its closest intruders and picks a speed advisory:

* action 0, decelerate: target speed 0 kts;
* action 1, hold: keep the current speed (target = current CAS);
* action 2, accelerate: target speed 150 kts;

bounded by the aircraft's envelope (an EC135 caps at 139.9 kt TAS). The reward
is R = R(s, h) + R(a) - Omega with, for the distance d to the closest intruder,
R(s, h) = -1 if d < NMAC, -alpha + delta d if NMAC <= d < d_max, else 0, and
R(a) = -psi for any advisory but hold. All defaults are the paper's table
(docs/usecase-corridor.md lists them with the feature scaling). ``variant="v1"``
(off by default) adds -hover_cost for every decision an aircraft spends hovering,
which the paper's reward leaves free.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import gymnasium as gym
import numpy as np

from aamsim.conflicts import pairs_within
from aamsim.metrics import record_advisories
from aamsim.units import KTS, R_EARTH
from rlbridge.observe import corridor_features, nearest_neighbours
from rlbridge.usecases.protocol import Feedback, Observations, UseCaseBase, make_params, start_overlay
from rlbridge.usecases.separation import apply_separation, check_distances, nmac_distance
from rlbridge.usecases.spec import SPEED_ROLES, UseCaseSpec
from rlbridge.usecases.variation import NYC_LANES_FT, PAPER_ALT_NOISE_FT, add_altitude_noise

if TYPE_CHECKING:
    from aamsim import Simulation

DECELERATE, HOLD, ACCELERATE = 0, 1, 2
VARIANTS = ("paper", "v1")
ACTION_NAMES = ("decelerate", "hold", "accelerate")


@dataclass(frozen=True)
class CorridorParams:
    """Use-case parameters; defaults are the paper's (Table: use-case hyper-parameters)."""

    nmac_m: float | None = None  # None: the simulation's separation standard (rlbridge.usecases.separation)
    lowc_m: float | None = None  # None: the simulation's separation standard
    speed_low_kts: float = 0.0  # "Desired speeds [0, Maintain, 150] knots"
    speed_high_kts: float = 150.0
    n_wpt: int = 2
    n_intruders: int = 30
    d_max_m: float = 3000.0
    alpha: float = 1.0
    delta: float = 0.0003
    psi: float = 0.001
    omega: float = 0.001
    nmac_penalty: float = 1.0  # R(s, h) inside NMAC: the paper's -1
    # Not given by the paper (documented choices):
    decision_interval_s: float = 10.0
    intruder_range_m: float = 10000.0
    obs_format: str = "flat"  # "flat" vector or "dict" (ownship, intruders, mask) for attention models
    # The paper's altitude noise (imperfect altitude holding, uniform +-100 ft), drawn per episode
    # seed at creation (rlbridge.usecases.variation); 0 flies the scenario's traffic as it is.
    alt_noise_ft: float = PAPER_ALT_NOISE_FT
    # The scenario's lanes [ft] (default: the shipped network's): an aircraft created within alt_noise_ft
    # of one gets its offset from it re-drawn (the noise replaces the scenario's); others get it added.
    alt_noise_lanes_ft: tuple[float, ...] = NYC_LANES_FT
    reward_interval_nmac: bool = True  # an NMAC during the interval counts even if over by the decision
    # The configuration: "paper" (the paper's reward, in which hovering is free) or "v1" (a hover
    # costs hover_cost per decision while the ground speed is under hover_speed_kts; docs/usecase-corridor.md,
    # "Variant v1"). Reports keep the two apart.
    variant: str = "paper"
    hover_cost: float = 0.0
    hover_speed_kts: float = 5.0
    # Extensions beyond the paper's state (off by default): horizontal vectors in the ownship's
    # track frame instead of east/north, and the intruders' velocity relative to the ownship.
    frame: str = "paper"  # "paper" (east, north) or "track" (along track, right of track)
    relative_velocity: bool = False
    # Feature scales (divisors): heading deg, altitude m, acceleration m/s^2, speed m/s, position m, d-alt m.
    scale_hdg: float = 360.0
    scale_alt: float = 1000.0
    scale_acc: float = 3.5
    scale_spd: float = 100.0
    scale_pos: float = 5000.0
    scale_dalt: float = 100.0
    # Real traffic as non-cooperative intruders (docs/real-traffic.md): a recording file or
    # opensky:LAT0,LON0,LAT1,LON1; its offset ([-][[HH:]MM:]SS or @UTC-TIME) and area (LAT0, LON0, LAT1, LON1).
    overlay: str = ""
    overlay_offset: str = ""
    overlay_area: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "alt_noise_lanes_ft", tuple(float(x) for x in self.alt_noise_lanes_ft))
        object.__setattr__(self, "overlay_area", tuple(float(x) for x in self.overlay_area))
        if len(self.overlay_area) not in (0, 4):
            raise ValueError("overlay_area is 4 numbers LAT0, LON0, LAT1, LON1 (or empty)")
        if self.obs_format not in ("flat", "dict"):
            raise ValueError(f"obs_format must be 'flat' or 'dict', not {self.obs_format!r}")
        if self.variant not in VARIANTS:
            raise ValueError(f"variant must be one of {', '.join(map(repr, VARIANTS))}, not {self.variant!r}")
        # The name says which reward it is: the paper's has no hover cost, v1 has one.
        if self.variant == "paper" and self.hover_cost != 0.0:
            raise ValueError("hover_cost is not part of the paper's reward: set variant='v1' to use it")
        if self.variant == "v1" and not self.hover_cost > 0.0:
            raise ValueError("variant 'v1' needs a positive hover_cost")
        if self.frame not in ("paper", "track"):
            raise ValueError(f"frame must be 'paper' or 'track', not {self.frame!r}")
        check_distances(self, "nmac_m", "lowc_m")
        for name in ("d_max_m", "decision_interval_s", "intruder_range_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive")
        if self.n_wpt < 0 or self.n_intruders < 0:
            raise ValueError("n_wpt and n_intruders cannot be negative")

    @classmethod
    def from_dict(cls, params: dict[str, Any] | None) -> CorridorParams:
        params_: CorridorParams = make_params(cls, params)
        return params_

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class CorridorSA(UseCaseBase):
    """The corridor separation-assurance use case (``corridor_sa``, ``aamgym/CorridorSA-v1``)."""

    name = "corridor_sa"
    env_name = "CorridorSA"
    # Its actions 0/1/2 decelerate / hold / accelerate; an action other than hold is an advisory.
    spec = UseCaseSpec(CorridorParams, action_kinds=("speed",), speed_actions=SPEED_ROLES,
                       baselines=("mvp_speed", "daa"), advisory="non_hold")
    fixed_traffic: ClassVar[dict[str, Any]] = {"alt_noise_ft": 0.0}
    conflicts_of_agents_only: ClassVar[bool] = True  # feedback: involved_since of its agents
    # Per agent: was it in an NMAC / LoWC event at some time during the interval.
    info_fields = {"nmac": np.bool_, "lowc": np.bool_}  # noqa: RUF012

    def __init__(self, **params: Any):
        self.params = CorridorParams.from_dict(params)
        p = self.params
        self.own_dim = 5 + 2 * p.n_wpt
        self.intruder_dim = 7 + 2 * p.n_wpt + (2 if p.relative_velocity else 0)
        self._scales = np.array([p.scale_hdg, p.scale_alt, p.scale_acc, p.scale_spd, p.scale_pos, p.scale_dalt])
        big = np.float32(1e6)
        if p.obs_format == "flat":
            dim = self.own_dim + p.n_intruders * self.intruder_dim
            self._obs_space: gym.Space = gym.spaces.Box(-big, big, shape=(dim,), dtype=np.float32)
        else:
            self._obs_space = gym.spaces.Dict({
                "ownship": gym.spaces.Box(-big, big, shape=(self.own_dim,), dtype=np.float32),
                "intruders": gym.spaces.Box(-big, big, shape=(p.n_intruders, self.intruder_dim), dtype=np.float32),
                "mask": gym.spaces.Box(0.0, 1.0, shape=(p.n_intruders,), dtype=np.float32),
            })
        self._act_space: gym.spaces.Discrete = gym.spaces.Discrete(3)
        self._pairs_memo: tuple[bytes, tuple[int, np.ndarray, np.ndarray, np.ndarray]] | None = None
        self._neighbours_memo: tuple[object, np.ndarray, tuple[np.ndarray, np.ndarray]] | None = None

    @property
    def decision_interval_s(self) -> float:
        return self.params.decision_interval_s

    # ------------------------------------------------------------------ spaces
    def observation_space(self) -> gym.Space:
        return self._obs_space

    def action_space(self) -> gym.Space:
        return self._act_space

    # -------------------------------------------------------------- lifecycle
    def attach(self, sim: Simulation) -> None:
        p = self.params
        apply_separation(sim, p.nmac_m, p.lowc_m)
        add_altitude_noise(sim, p.alt_noise_ft, p.alt_noise_lanes_ft, "corridor.alt_noise")
        start_overlay(sim, p.overlay, p.overlay_offset, p.overlay_area)

    # ------------------------------------------------------------ observation
    def _route_arrays(self, sim: Simulation, slots: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Destination and next ``n_wpt`` waypoints of every aircraft (the destination repeats at the end).

        ``slots``: only these aircraft's rows are filled (the others are not read: an observation of a
        few agents needs them and their intruders only; the routes are read one aircraft at a time).
        """
        view = sim.view
        n = view.n
        nw = self.params.n_wpt
        dest_lat = np.full(n, np.nan)
        dest_lon = np.full(n, np.nan)
        wlat = np.empty((n, nw))
        wlon = np.empty((n, nw))
        lat, lon, lnav = view.lat, view.lon, view.lnav
        for s in range(n) if slots is None else slots.tolist():
            route = view.route(s)
            wps = route.waypoints
            if wps:
                rec = view.flight(s)
                if rec.destination and not math.isnan(rec.dest_lat):
                    dest_lat[s], dest_lon[s] = rec.dest_lat, rec.dest_lon
                else:
                    dest_lat[s], dest_lon[s] = wps[-1].lat, wps[-1].lon
                start = route.iactwp if lnav[s] and route.iactwp >= 0 else len(wps)
                for j in range(nw):
                    k = start + j
                    if k < len(wps):
                        wlat[s, j], wlon[s, j] = wps[k].lat, wps[k].lon
                    else:
                        wlat[s, j], wlon[s, j] = dest_lat[s], dest_lon[s]
            else:
                # No route: the aircraft's own position (zero offsets, zero distance).
                dest_lat[s], dest_lon[s] = lat[s], lon[s]
                wlat[s, :] = lat[s]
                wlon[s, :] = lon[s]
        dlat = np.radians(dest_lat - lat)
        dlon = np.radians((dest_lon - lon + 180.0) % 360.0 - 180.0)
        ddest = R_EARTH * np.hypot(dlat, dlon * np.cos(np.radians(0.5 * (dest_lat + lat))))
        return ddest, wlat, wlon, dest_lat, dest_lon

    def _pairs(self, sim: Simulation) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        """Aircraft pairs within range and their slant distances.

        A pure function of the traffic's position, altitude, track and ground
        speed arrays, memoised on them: a step observes the agents and then asks
        for their closest distances on the same state, which then costs one search.
        """
        t = sim.view
        # The state's bytes, compared in one go (five array_equal calls and copies cost more than the
        # search itself at a few dozen aircraft: the vector environments step thousands of episodes).
        key = b"".join([t.lat.tobytes(), t.lon.tobytes(), t.alt.tobytes(), t.trk.tobytes(), t.gs.tobytes()])
        memo = self._pairs_memo
        if memo is not None and memo[0] == key:
            return memo[1]
        rng = max(self.params.intruder_range_m, self.params.d_max_m)
        pi, pj, d = pairs_within(sim, rng)
        result = (t.n, pi, pj, d)
        self._pairs_memo = (key, result)
        return result

    def _neighbours(self, sim: Simulation, slots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pairs = self._pairs(sim)
        memo = self._neighbours_memo
        if memo is not None and memo[0] is pairs and np.array_equal(memo[1], slots):
            return memo[2]  # the closest distances of the agents just observed (feedback after observe)
        n, pi, pj, d = pairs
        rng = max(self.params.intruder_range_m, self.params.d_max_m)
        k = max(self.params.n_intruders, 1)
        result = nearest_neighbours(n, slots, pi, pj, d, k, rng)
        self._neighbours_memo = (pairs, slots.copy(), result)
        return result

    def observe(self, sim: Simulation, agents: list[str]) -> Observations:
        slot = sim.view.slot
        slots = np.array([slot(a) for a in agents], dtype=np.int64)
        nbr, nbr_d = self._neighbours(sim, slots)
        self._last_closest = nbr_d[:, 0].copy() if len(slots) else np.empty(0)
        if self.params.n_intruders == 0:
            nbr, nbr_d = nbr[:, :0], nbr_d[:, :0]
        needed = np.unique(np.concatenate([slots, nbr[nbr >= 0]])) if len(slots) < sim.view.n else None
        ddest, wlat, wlon, _, _ = self._route_arrays(sim, needed)
        t = sim.view
        own, intr, mask = corridor_features(
            slots, t.lat, t.lon, t.alt, t.hdg, t.trk, t.ax, t.gs, ddest, wlat, wlon, nbr, nbr_d, self._scales,
            self.params.frame == "track", self.params.relative_velocity,
        )
        if self.params.obs_format == "dict":
            return Observations(parts={"ownship": own, "intruders": intr, "mask": mask})
        flat = np.concatenate([own, intr.reshape(len(slots), -1)], axis=1)
        return Observations(flat=flat)

    def closest_distances(self, sim: Simulation, agents: list[str]) -> np.ndarray:
        """3-D distance to the closest intruder within d_max (inf beyond)."""
        slot = sim.view.slot
        slots = np.array([slot(a) for a in agents], dtype=np.int64)
        _, nbr_d = self._neighbours(sim, slots)
        return nbr_d[:, 0].copy() if len(slots) else np.empty(0)

    # ----------------------------------------------------------------- reward
    def feedback(self, sim: Simulation, agents: list[str], actions: dict[str, Any], since_s: float) -> Feedback:
        """Rewards from the closest intruder now and the interval's NMACs; info flags NMAC and LoWC events."""
        service = sim.services.conflicts
        nmac_min = service.involved_since("nmac", since_s)
        lowc = service.involved_since("lowc", since_s)
        closest = self.closest_distances(sim, agents) if agents else np.empty(0)
        rewards = self.rewards(sim, agents, actions, closest, nmac_min)
        info = {"nmac": np.array([a in nmac_min for a in agents], dtype=np.bool_),
                "lowc": np.array([a in lowc for a in agents], dtype=np.bool_)}
        return Feedback(rewards, info)

    def rewards(self, sim: Simulation, agents: list[str], actions: dict[str, Any],
                closest_m: np.ndarray, interval_nmac_min_m: dict[str, float]) -> np.ndarray:
        """Per-agent reward from the closest-intruder distance and the advisory given."""
        p = self.params
        d = np.array(closest_m, dtype=float)
        if p.reward_interval_nmac and interval_nmac_min_m:  # most intervals have no NMAC at all
            for k, a in enumerate(agents):
                if a in interval_nmac_min_m:
                    d[k] = min(d[k], interval_nmac_min_m[a])
        r_sh = np.where(d < nmac_distance(sim), -p.nmac_penalty, np.where(d < p.d_max_m, -p.alpha + p.delta * d, 0.0))
        psi = -p.psi
        get = actions.get
        r_a = np.array([0.0 if get(a, HOLD) == HOLD else psi for a in agents], dtype=np.float64)
        r_hover = -p.hover_cost * self.hovering(sim, agents) if p.hover_cost > 0 else 0.0
        return r_sh + r_a + r_hover - p.omega

    def hovering(self, sim: Simulation, agents: list[str]) -> np.ndarray:
        """1.0 for agents whose ground speed is under ``hover_speed_kts`` now (airborne and parked), else 0."""
        if not agents:
            return np.zeros(0)
        slot = sim.view.slot
        slots = np.array([slot(a) for a in agents], dtype=np.int64)
        return (np.abs(sim.view.gs[slots]) < self.params.hover_speed_kts * KTS).astype(float)

    # ----------------------------------------------------------------- action
    def speed_action_targets(self, sim: Simulation, slots: np.ndarray) -> np.ndarray:
        """CAS [m/s] each action selects per aircraft: decelerate, hold (the current CAS), accelerate."""
        p = self.params
        cas = np.asarray(sim.view.cas[slots], dtype=np.float64)
        return np.stack([np.full_like(cas, p.speed_low_kts * KTS), cas, np.full_like(cas, p.speed_high_kts * KTS)],
                        axis=1)

    def idle_decisions_change_nothing(self, sim: Simulation) -> bool:
        return True  # apply_actions({}) returns at once

    def apply_actions(self, sim: Simulation, actions: dict[str, Any]) -> None:
        """Speed advisories: set the selected CAS of each agent (missing agents: no advisory).

        All actions are checked before any is applied.
        """
        find = sim.view.find
        p = self.params
        slots: list[int] = []
        codes: list[int] = []
        advised: list[int] = []  # slots advised other than hold (hold advisories are not alerts)
        names: list[str] = []
        for acid, action in actions.items():
            i = find(acid)
            if i is None:
                continue
            a = int(action)
            if a != HOLD:
                if a != DECELERATE and a != ACCELERATE:
                    raise ValueError(f"action {action!r} for {acid} is not 0, 1 or 2")
                advised.append(i)
                names.append(ACTION_NAMES[a])
            slots.append(i)
            codes.append(a)
        if not slots:
            return
        idx = np.array(slots, dtype=np.int64)
        code = np.array(codes, dtype=np.int64)
        target = np.where(code == DECELERATE, p.speed_low_kts * KTS,
                          np.where(code == ACCELERATE, p.speed_high_kts * KTS, sim.view.cas[idx]))
        sim.select_speed(idx, target)
        record_advisories(sim, advised, names)
