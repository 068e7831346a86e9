"""The detect-and-avoid baseline (``baseline=daa``): DO-365 / DAIDALUS alerting and speed bands as a policy.

The open real-world counterpart of the learned separation policies: at each
decision, every agent's alert level and ground-speed bands come from
:class:`aamsim.resolution.DetectAndAvoid` (the logic behind ``RESO DAA``). It is
speed-only and acts through the use case's own discrete actions, so its
advisories are those a learned policy could give:

* an agent alerted at the resolution level (corrective by default) whose
  current speed loses well clear gets the action whose speed after one decision
  interval (the aircraft's acceleration limit applied) is conflict-free, on the
  side the pair's coordination gives it (the aircraft passing first keeps or
  gains speed, the other slows: :meth:`aamsim.resolution.DetectAndAvoid.sides`),
  and closest to its current speed; when there is none, the action that ends
  closest to the DAA resolution speed (the conflict-free speed closest to the
  current one, or the recovery speed when the bands saturate);
* the advisory is held while the agent is alerted or its own speed, noted at
  the first advisory, would still lose well clear: each decision it gets the
  same choice again, which is the hold action once its speed is conflict-free;
* clear of conflict, the agent steers back to its own speed (the action ending
  closest to it; of two nearby agents ready at once, one first:
  :meth:`aamsim.resolution.DetectAndAvoid.resume_order`) and gets no advisory
  once within ``resume_band_kts`` of it, or once no action brings it closer
  (the use case's actions may be coarser than the band).

Agents never alerted get no advisory (as the unequipped aircraft). The use case
must say which speed each action selects (:class:`rlbridge.usecases.protocol.SpeedActions`):
``corridor_sa`` and ``reach_destination`` do. On a use case whose advisories are
headings and altitudes (its spec's ``action_kinds``; ``heading_altitude_sa``), the same
logic turns and changes level: :mod:`rlbridge.agents.daa_manoeuvre`. A use case
with none of these kinds is refused, naming its kinds.

It acts on the step result (each action's targets, ``info["action_targets"]``:
:mod:`rlbridge.usecases.targets`) and a traffic snapshot of ``snapshot_fields``, read by the
DAA logic as a kinematic state (:class:`aamsim.resolution.state.SnapshotState`), so it runs on
every backend and decides the same in process and over ZeroMQ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from aamsim.resolution import DAAParams, DetectAndAvoid, SpeedBands
from aamsim.resolution.state import AXIS_FIELDS, SnapshotState
from aamsim.snapshots import TrafficSnapshot
from aamsim.units import KTS
from rlbridge.agents.daa_manoeuvre import ManoeuvreDAA
from rlbridge.agents.manoeuvres import ActionTargets
from rlbridge.agents.rollout import ActOutput
from rlbridge.core import StepResult
from rlbridge.usecases.protocol import ADVISORY_KINDS
from rlbridge.usecases.spec import Needs, check_fits, spec_of
from rlbridge.usecases.targets import published_targets


@dataclass(frozen=True)
class DAAPolicyConfig:
    """Parameters of the DAA baseline: DAA thresholds (``DAAParams`` names) and the resumption band."""

    daa: dict[str, Any] = field(default_factory=dict)  # overrides of aamsim.resolution.DAAParams
    resume_band_kts: float = 8.0  # no advisory once this close to the agent's own speed


@dataclass(frozen=True)
class _UseCaseFacts:
    """What the decisions read of the use case, noted by ``check_usecase``."""

    kinds: tuple[str, ...]  # its action kinds
    decision_interval_s: float
    resume: int | None  # heading / altitude use cases: the action that gives no advisory
    climb_rate_mps: float  # heading / altitude use cases: the vertical speed of level changes


def _published_rows(published: dict[str, Any], kind: str, names: list[str]) -> np.ndarray:
    """The published targets of ``kind`` of the agents ``names``, in that order: (len(names), n_actions)."""
    row = {a: q for q, a in enumerate(published["agents"])}
    return np.asarray(published[kind], dtype=np.float64)[[row[a] for a in names]]


@dataclass
class _Held:
    action: int
    resume_cas: float  # the agent's own selected CAS when first advised [m/s]


class DAAActor:
    """Speed-only detect and avoid on a use case's discrete speed actions (see the module docstring)."""

    obs_format: str | None = None
    # What the DAA logic reads (aamsim.resolution.state), the own speed (selspd) and, for heading / altitude
    # actions, the selected altitude (a use case without altitude actions keeps it).
    snapshot_fields: tuple[str, ...] = (*AXIS_FIELDS, "selspd", "selalt")
    # Speed actions of either layout (it steers with their targets), or heading / altitude actions.
    needs: ClassVar[Needs] = Needs(any_of=ADVISORY_KINDS)
    reads_action_targets: ClassVar[bool] = True  # the episode engine publishes them while it plays

    def __init__(self, config: DAAPolicyConfig | None = None):
        self.config = config or DAAPolicyConfig()
        self.daa = DetectAndAvoid(DAAParams(**self.config.daa))
        self._held: dict[str, _Held] = {}
        self._own: dict[str, float] = {}  # each agent's own CAS, noted at its first advisory [m/s]
        self._episode: np.random.Generator | None = None  # the current episode's action generator
        self._manoeuvre = ManoeuvreDAA(self.daa)
        self._usecase: _UseCaseFacts | None = None  # check_usecase

    def set_weights(self, weights: Any) -> None:
        pass

    def check_usecase(self, usecase: Any) -> None:
        """Refuse a use case with neither speed nor heading / altitude actions, naming its kinds; note what
        the decisions read of it (its kinds, decision interval, resume action and climb rate)."""
        if usecase is not None:
            check_fits(self.needs, usecase, "baseline daa")
            kinds = tuple(spec_of(usecase).action_kinds)
            resume = getattr(usecase, "resume_action", None)
            if "speed" not in kinds and resume is None:
                raise TypeError(f"use case {usecase.name} has heading/altitude actions but names no resume_action")
            self._usecase = _UseCaseFacts(kinds, float(usecase.decision_interval_s),
                                          None if resume is None else int(resume),
                                          float(getattr(usecase, "climb_rate_mps", 5.08)))

    def act(self, result: StepResult, snapshot: TrafficSnapshot | None, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput:
        if snapshot is None:
            raise ValueError(f"baseline daa reads a traffic snapshot of {', '.join(self.snapshot_fields)}")
        if self._usecase is None:
            raise RuntimeError("baseline daa acts after check_usecase(usecase) (its actions and decision interval)")
        if rng is not self._episode:  # a new episode (each has its own generator): forget the previous aircraft
            self._episode, self._held, self._own = rng, {}, {}
            self._manoeuvre = ManoeuvreDAA(self.daa)
        published = published_targets(result.info, "baseline daa")
        sim = SnapshotState(snapshot)
        facts = self._usecase
        if "speed" not in facts.kinds:
            return self._act_manoeuvres(result, sim, published, facts)
        view = sim.view
        alive = set(result.alive)
        rows = [k for k, a in enumerate(result.agents) if a in alive and a in view]
        actions = np.zeros(len(result.agents), dtype=np.int64)
        advise = np.zeros(len(result.agents), dtype=bool)
        if not rows:
            return ActOutput(actions, advise=advise)
        names = [result.agents[k] for k in rows]
        slots = np.array([view.slot(a) for a in names], dtype=np.int64)
        alerts = self.daa.alerts(sim)
        level = alerts.level[slots]
        alerted = level >= self.daa.params.resolve_level
        involved = alerted | np.array([a in self._held for a in names], dtype=bool)
        bands = self.daa.gs_bands(sim, slots[involved])
        # The speed each action reaches within one decision interval, as ground speed.
        targets = _published_rows(published, "speed", names)
        cas = np.asarray(view.cas[slots], dtype=np.float64)[:, None]
        step = (np.asarray(view.axmax[slots], dtype=np.float64) * facts.decision_interval_s)[:, None]
        end_cas = cas + np.clip(targets - cas, -step, step)
        end_gs = np.stack([self.daa.gs_for(sim, slots, end_cas[:, a]) for a in range(targets.shape[1])], axis=1)
        end_gs = np.clip(end_gs, bands.gmin[slots][:, None], bands.gmax[slots][:, None])
        resolve: list[int] = []
        ready: list[int] = []
        for r, (acid, i) in enumerate(zip(names, slots.tolist())):
            held = self._held.get(acid)
            if held is None:
                if alerted[r] and bands.conflicts(i, float(view.gs[i])):
                    resolve.append(r)
                continue
            own_gs = float(self.daa.gs_for(sim, slots[r:r + 1], np.array([held.resume_cas]))[0])
            if alerted[r] or bands.conflicts(i, own_gs):
                resolve.append(r)  # still advised: re-chosen each decision (hold once conflict-free)
            elif abs(float(view.cas[i]) - held.resume_cas) <= self.config.resume_band_kts * KTS:
                del self._held[acid]  # back at its own speed: no advisory
            else:
                ready.append(r)
        if ready:
            # Each ready agent's own trajectory: its own speed along its track.
            resumed_gs = self.daa.gs_for(sim, slots[ready], np.array([self._held[names[r]].resume_cas for r in ready]))
            trk = np.radians(np.asarray(view.trk, dtype=np.float64)[slots[ready]])
            vel = np.column_stack([resumed_gs * np.sin(trk), resumed_gs * np.cos(trk), view.vs[slots[ready]]])
            go = self.daa.resume_order(sim, slots[ready], vel)
            for r, now in zip(ready, go.tolist()):
                if now:  # steer back to its own speed
                    held = self._held[names[r]]
                    gap = np.abs(end_cas[r] - held.resume_cas)
                    best = int(np.argmin(gap))
                    if gap[best] >= abs(float(cas[r, 0]) - held.resume_cas) - 1e-6:
                        # No action brings it closer to its own speed (the actions are coarser than the
                        # resumption band): it holds the speed it has, which is as close as it gets, and is
                        # clear of conflict. Kept as "ready", it would defer every nearby aircraft with a
                        # later callsign (resume_order) for as long as it flies: aircraft held hovering
                        # for minutes (docs/daa.md).
                        del self._held[names[r]]
                        actions[rows[r]] = int(np.argmin(np.abs(targets[r] - cas[r, 0])))
                        advise[rows[r]] = True
                        continue
                    held.action = best
                    actions[rows[r]], advise[rows[r]] = held.action, True
                else:
                    resolve.append(r)  # waits for the one resuming first (holds once conflict-free)
        if resolve:
            idx = np.array(resolve, dtype=np.int64)
            sides = self.daa.sides(sim, alerts, slots[idx])
            goal, _ = self.daa.resolutions(sim, slots[idx], bands, sides)
            for r, g, side in zip(idx.tolist(), goal.tolist(), sides.tolist()):
                a = self._choose(bands, int(slots[r]), end_gs[r], np.abs(targets[r] - cas[r, 0]),
                                 float(view.gs[slots[r]]), g, side)
                acid = names[r]
                held = self._held.get(acid)
                if held is None:
                    # Its own speed: the one selected before its first advisory of the episode (a later
                    # advisory finds the speed an earlier one left, e.g. a hover).
                    own = self._own.setdefault(acid, float(view.selspd[slots[r]]))
                    self._held[acid] = _Held(a, own)
                else:
                    held.action = a
                actions[rows[r]], advise[rows[r]] = a, True
        return ActOutput(actions, advise=advise)

    def _act_manoeuvres(self, result: StepResult, sim: SnapshotState, published: dict[str, Any],
                        facts: _UseCaseFacts) -> ActOutput:
        """Heading and altitude advisories (rlbridge.agents.daa_manoeuvre)."""
        view = sim.view
        alive = set(result.alive)
        rows = [k for k, a in enumerate(result.agents) if a in alive and a in view]
        actions = np.zeros(len(result.agents), dtype=np.int64)
        advise = np.zeros(len(result.agents), dtype=bool)
        if rows:
            names = [result.agents[k] for k in rows]
            slots = np.array([view.slot(a) for a in names], dtype=np.int64)
            assert facts.resume is not None  # check_usecase refused a heading / altitude use case without one
            n_actions = int(next(v for k, v in published.items() if k != "agents").shape[1])
            trk = _published_rows(published, "heading", names) if "heading" in facts.kinds else \
                np.repeat(np.asarray(view.trk, dtype=np.float64)[slots, None], n_actions, axis=1)
            alt = _published_rows(published, "altitude", names) if "altitude" in facts.kinds else \
                np.repeat(np.asarray(view.selalt, dtype=np.float64)[slots, None], n_actions, axis=1)
            targets = ActionTargets(trk, alt, facts.resume, facts.climb_rate_mps)
            acts, adv = self._manoeuvre.act(sim, targets, names, slots)
            actions[rows], advise[rows] = acts, adv
        return ActOutput(actions, advise=advise)

    @staticmethod
    def _choose(bands: SpeedBands, slot: int, end_gs: np.ndarray, change: np.ndarray, gs: float, goal: float,
                side: int) -> int:
        """The action for a resolution (see the module docstring).

        Among the actions ending conflict-free on the resolution's side (faster for
        an aircraft that passes first, slower for one that yields), the one ending
        closest to the current speed; an aircraft passing first with none keeps its
        speed; otherwise the action ending closest to the DAA resolution speed. Ties go
        to the action asking the smallest change (``change``: |target - current| CAS).
        """
        actions = range(end_gs.shape[0])
        free = [a for a in actions if not bands.conflicts(slot, float(end_gs[a]))]
        sided = [a for a in free if side == 0 or (end_gs[a] - gs) * side >= 0]
        if sided:
            return min(sided, key=lambda a: (abs(float(end_gs[a]) - gs), float(change[a]), a))
        ref = gs if math.isnan(goal) else goal  # NaN: passes first at its speed (or nothing avoids recovery)
        return min(actions, key=lambda a: (abs(float(end_gs[a]) - ref), float(change[a]), a))
