"""Non-learned baselines: the unequipped aircraft and a speed-only MVP conflict resolution.

* :class:`UnequippedActor` — the paper's baseline: no advisory at all; every aircraft flies
  its pre-departure flight plan (its scenario speeds and route).
* :class:`SpeedMVPActor` — state-based conflict detection with a look-ahead (BlueSky's
  STATEBASED method) and the Modified Voltage Potential resolution (Eby 1994; Hoekstra,
  van Gent & Ruigrok 2002, as in BlueSky's MVP with the speed-only option) projected on the
  ownship's track, so that it only changes speed, like the agents. The continuous MVP speed
  change is tracked with the use case's discrete advisories (decelerate / hold / accelerate); a
  degenerate pair (same point at the same time, collinear paths) is sequenced instead: the
  aircraft in the lower traffic slot yields. Without
  a conflict an aircraft that was advised before resumes its flight-plan speed (accelerate
  or decelerate back into a band around it, then hold); one never advised gets no advisory.
  docs/algorithms.md describes it.

Both act on the step result and a traffic snapshot (:class:`aamsim.snapshots.TrafficSnapshot`,
``snapshot_fields``), never on the simulation, so they run on every episode backend.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from aamsim.conflicts.pairs import statebased
from aamsim.conflicts.separation import PAPER_STANDARD, SeparationStandard
from aamsim.conflicts.service import search_pairs
from aamsim.resolution.state import KINEMATIC_FIELDS, conflict_geometry
from aamsim.snapshots import TrafficSnapshot
from aamsim.units import KTS
from rlbridge.agents.rollout import ActOutput
from rlbridge.core import StepResult
from rlbridge.usecases.spec import SPEED_ROLES, Needs, check_fits

DECELERATE, HOLD, ACCELERATE = 0, 1, 2


def protected_zone(rpz_m: float | None, hpz_m: float | None,
                   standard: SeparationStandard | None) -> tuple[float, float]:
    """A baseline's protected zone: radius and vertical half-height [m].

    A value of None takes the separation standard's: its LoWC distance as the radius and its NMAC
    vertical extent as the half-height (``standard`` None: the paper's, 450 m and 150 m).
    """
    std = standard if standard is not None else PAPER_STANDARD
    return (float(rpz_m) if rpz_m is not None else std.lowc_horizontal_m,
            float(hpz_m) if hpz_m is not None else std.nmac_vertical_m)


class UnequippedActor:
    """No advisories: the aircraft fly their flight plans (the paper's baseline)."""

    obs_format: str | None = None
    snapshot_fields: tuple[str, ...] = ()
    needs: ClassVar[Needs] = Needs()  # fits every use case

    def set_weights(self, weights: Any) -> None:
        pass

    def act(self, result: StepResult, snapshot: TrafficSnapshot | None, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput:
        return ActOutput(None)


@dataclass(frozen=True)
class SpeedMVPConfig:
    """Parameters of the speed-only MVP baseline (distances in m, times in s, speeds in kt)."""

    lookahead_s: float = 120.0  # conflict detection look-ahead
    # Protected zone radius [m]; None: the LoWC distance of the snapshot's separation standard (the
    # simulation's; the paper's 450 m).
    rpz_m: float | None = None
    # Vertical half-height of the protected zone; None: the NMAC distance of the separation standard (its
    # vertical extent; the paper's 150 m). Not the LoWC sphere's 450 m: corridor layers
    # are 700 ft (213 m) apart, and a speed change cannot separate two flights crossing in
    # different layers; reacting to them stalls whole corridors (3 seeds of nyc_train_100:
    # hpz 450 m -> 20 NMAC per episode and aircraft still flying at the time limit; 150 m -> 6.3;
    # unequipped 14.3).
    hpz_m: float | None = None
    margin: float = 1.1  # MVP resolves to margin * rpz at the closest point of approach
    act_band_kts: float = 2.0  # speed changes smaller than this are a hold
    resume_band_kts: float = 8.0  # hold once within this band of the flight-plan speed


class SpeedMVPActor:
    """Speed-only Modified Voltage Potential conflict resolution (see the module docstring)."""

    obs_format: str | None = None
    snapshot_fields: tuple[str, ...] = (*KINEMATIC_FIELDS, "trk", "cas", "selspd")
    # Its actions 0/1/2 are decelerate / hold / accelerate: on fixed speed targets (reach_destination's
    # 30/60/90 kt) its "hold" would select 60 kt, so such a use case is refused.
    needs: ClassVar[Needs] = Needs(any_of=("speed",), speed_actions=SPEED_ROLES)

    def __init__(self, config: SpeedMVPConfig | None = None):
        self.config = config or SpeedMVPConfig()
        self._cruise: dict[str, float] = {}  # flight-plan CAS [m/s] noted before any advisory
        self._advised: set[str] = set()
        self._episode: np.random.Generator | None = None  # the current episode's action generator

    def set_weights(self, weights: Any) -> None:
        pass

    def check_usecase(self, usecase: Any) -> None:
        """Its actions 0/1/2 are decelerate / hold / accelerate: refuse a use case without that speed layout."""
        if usecase is not None:
            check_fits(self.needs, usecase, "baseline mvp_speed")

    def speed_changes(self, snap: TrafficSnapshot) -> np.ndarray:
        """Per snapshot row: summed MVP speed change along track [m/s] (NaN: no conflict)."""
        c = self.config
        rpz_m, hpz_m = protected_zone(c.rpz_m, c.hpz_m, snap.separation)
        s = conflict_geometry(snap)
        n = len(s.ids)
        out = np.full(n, np.nan)
        if n < 2:
            return out
        pi, pj = search_pairs(s, np.zeros(n), np.full(n, c.lookahead_s), rpz_m)
        if pi.size == 0:
            return out
        conf, tcpa, _, _, _, los = statebased(s.lat, s.lon, s.alt, s.u, s.v, s.w, pi, pj,
                                                 rpz_m, hpz_m, c.lookahead_s)
        sel = np.flatnonzero(conf | los)
        trk = np.radians(snap.trk)
        ex, ey = np.sin(trk), np.cos(trk)
        for k in sel:
            i, j = int(pi[k]), int(pj[k])
            # Position of j relative to i now, and relative velocity (local flat frame).
            dx, dy = s.x[j] - s.x[i], s.y[j] - s.y[i]
            du, dv = s.u[j] - s.u[i], s.v[j] - s.v[i]
            t = max(float(tcpa[k]), 1.0)  # in loss of separation (t <= 0) act within a second
            cx, cy = dx + du * max(float(tcpa[k]), 0.0), dy + dv * max(float(tcpa[k]), 0.0)
            dist = math.hypot(cx, cy)
            if dist < 1.0:
                # Degenerate geometry (both reach the same point together, collinear paths): MVP has
                # no direction; sequence the pair instead, the lower traffic slot yields.
                cx, cy, dist = ex[i], ey[i], 0.0
            # MVP: each aircraft moves its CPA away from the other to margin * rpz.
            push = (c.margin * rpz_m - dist) / t
            norm = math.hypot(cx, cy) or 1.0
            ux, uy = cx / norm, cy / norm  # unit vector from i towards j at CPA
            for a, sign in ((i, -1.0), (j, 1.0)):
                dva = sign * push * (ux * ex[a] + uy * ey[a])
                out[a] = dva if math.isnan(out[a]) else out[a] + dva
        return out

    def act(self, result: StepResult, snapshot: TrafficSnapshot | None, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput:
        if snapshot is None:
            raise ValueError(f"baseline mvp_speed reads a traffic snapshot of {', '.join(self.snapshot_fields)}")
        if rng is not self._episode:  # a new episode (each has its own generator): forget the previous aircraft
            self._episode, self._cruise, self._advised = rng, {}, set()
        snap = snapshot
        row = {a: i for i, a in enumerate(snap.ids)}
        band = self.config.resume_band_kts * KTS
        act_band = self.config.act_band_kts * KTS
        dv = self.speed_changes(snap)
        selspd, cas_now = snap.selspd, snap.cas
        actions = np.full(len(result.agents), HOLD, dtype=np.int64)
        advise = np.zeros(len(result.agents), dtype=bool)
        alive = set(result.alive)
        for k, a in enumerate(result.agents):
            i = row.get(a)
            if i is None or a not in alive:
                continue
            if a not in self._cruise:
                self._cruise[a] = float(selspd[i])
            if not math.isnan(dv[i]):
                # Track the MVP resolution speed with the discrete advisories.
                actions[k] = ACCELERATE if dv[i] > act_band else DECELERATE if dv[i] < -act_band else HOLD
                advise[k] = True
                self._advised.add(a)
            elif a in self._advised:
                cas, cruise = float(cas_now[i]), self._cruise[a]
                actions[k] = ACCELERATE if cas < cruise - band else DECELERATE if cas > cruise + band else HOLD
                advise[k] = True
        return ActOutput(actions, advise=advise)
