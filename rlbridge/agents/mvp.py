"""The ``mvp`` baseline: BlueSky's Modified Voltage Potential by heading and altitude, on a use case's actions.

For use cases whose advisories are headings and altitudes
(its spec's ``action_kinds``; ``heading_altitude_sa``), as ``mvp_speed`` is for speed
advisories: BlueSky's state-based detection and MVP resolution
(:mod:`aamsim.resolution.mvp_detect`, :func:`aamsim.resolution.mvp_service.mvp_commands`,
the same cycle as ``RESO MVP``, horizontal and vertical) give every aircraft in
conflict a track and an altitude; the agent gets the action whose targets are
closest to them (``|turn| / largest turn + |altitude difference| / largest
change``; a use case without altitude actions compares tracks only). An agent
advised before and now without conflict gets the resume action once (back on
its route, at its own altitude), then no advisory; one never advised gets
none (as the unequipped aircraft).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from aamsim.resolution.mvp import MVPSettings
from aamsim.resolution.mvp_detect import detect_on
from aamsim.resolution.mvp_service import mvp_commands_on
from aamsim.snapshots import TrafficSnapshot
from rlbridge.agents.baselines import KINEMATIC_FIELDS, conflict_geometry, protected_zone
from rlbridge.agents.rollout import ActOutput
from rlbridge.core import StepResult
from rlbridge.usecases.spec import Needs, check_fits
from rlbridge.usecases.targets import MANOEUVRE_KINDS, published_targets


@dataclass(frozen=True)
class MVPConfig:
    """Parameters of the heading / altitude MVP baseline (distances m, times s)."""

    lookahead_s: float = 120.0  # conflict detection look-ahead (as mvp_speed)
    # Protected zone radius [m]; None: the LoWC distance of the simulation's separation standard.
    rpz_m: float | None = None
    # Vertical half-height [m]; None: the standard's NMAC distance (corridor layers are 213 m apart).
    hpz_m: float | None = None


class MVPActor:
    """Heading and altitude MVP on a use case's discrete advisories (see the module docstring).

    It acts on the step result (the targets of each action, ``info["action_targets"]``:
    :mod:`rlbridge.usecases.targets`, published because it asks, ``reads_action_targets``) and
    a traffic snapshot, so it runs on every backend.
    """

    obs_format: str | None = None
    snapshot_fields: tuple[str, ...] = (*KINEMATIC_FIELDS, "trk", "gs", "created_s", "selalt", "ap_vs", "vmin",
                                        "vmax", "vsmin", "vsmax")
    needs: ClassVar[Needs] = Needs(any_of=MANOEUVRE_KINDS)  # heading or altitude actions
    reads_action_targets: ClassVar[bool] = True  # the episode engine publishes them while it plays

    def __init__(self, config: MVPConfig | None = None):
        self.config = config or MVPConfig()
        self.settings = MVPSettings(horizontal=False)  # heading, speed and vertical: no restriction
        self._advised: set[str] = set()
        self._episode: np.random.Generator | None = None  # the current episode's action generator
        self._resume: int | None = None  # the use case's resume action (check_usecase)

    def set_weights(self, weights: Any) -> None:
        pass

    def check_usecase(self, usecase: Any) -> None:
        """Refuse a use case with neither heading nor altitude actions, naming its kinds; note its resume action."""
        if usecase is not None:
            check_fits(self.needs, usecase, "baseline mvp")
            resume = getattr(usecase, "resume_action", None)
            if resume is None:
                raise TypeError(f"use case {usecase.name} has heading/altitude actions but names no resume_action")
            self._resume = int(resume)

    def act(self, result: StepResult, snapshot: TrafficSnapshot | None, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput:
        if snapshot is None:
            raise ValueError(f"baseline mvp reads a traffic snapshot of {', '.join(self.snapshot_fields)}")
        if self._resume is None:
            raise RuntimeError("baseline mvp acts after check_usecase(usecase) (its resume action)")
        if rng is not self._episode:  # a new episode (each has its own generator): forget the previous aircraft
            self._episode, self._advised = rng, set()
        snap = snapshot
        row = {a: i for i, a in enumerate(snap.ids)}
        alive = set(result.alive)
        rows = [k for k, a in enumerate(result.agents) if a in alive and a in row]
        actions = np.zeros(len(result.agents), dtype=np.int64)
        advise = np.zeros(len(result.agents), dtype=bool)
        if not rows:
            return ActOutput(actions, advise=advise)
        published = published_targets(result.info, "baseline mvp")
        c = self.config
        rpz_m, hpz_m = protected_zone(c.rpz_m, c.hpz_m, snap.separation)
        conf = detect_on(snap, conflict_geometry(snap) if len(snap.ids) > 1 else None, rpz_m, hpz_m, c.lookahead_s)
        # Every pair from both sides: the rows of a non-cooperative ownship change only that aircraft's
        # commands, and it is never an agent.
        keep = np.ones(conf.own.shape[0], dtype=bool)
        trk, _gs, _vs, alt = mvp_commands_on(snap, conf, keep, self.settings, rpz_m, hpz_m, c.lookahead_s)
        in_conflict = np.zeros(len(snap.ids), dtype=bool)
        in_conflict[conf.own] = True
        target_row = {a: q for q, a in enumerate(published["agents"])}
        now_trk, now_alt = snap.trk, snap.selalt
        for k in rows:
            acid = result.agents[k]
            i, q = row[acid], target_row[acid]
            if in_conflict[i]:
                t_trk = published["heading"][q] if "heading" in published else np.full(
                    self._n_actions(published), float(now_trk[i]))
                t_alt = published["altitude"][q] if "altitude" in published else np.full(
                    self._n_actions(published), float(now_alt[i]))
                turn = np.abs((t_trk - trk[i] + 180.0) % 360.0 - 180.0)
                dz = np.abs(t_alt - alt[i])
                span_t = float(np.ptp(t_trk)) or 1.0
                span_z = float(np.ptp(t_alt)) or 1.0
                cost = turn / span_t + dz / span_z
                actions[k] = int(np.lexsort((np.arange(cost.size), cost))[0])
                advise[k] = True
                self._advised.add(acid)
            elif acid in self._advised:
                self._advised.discard(acid)
                actions[k], advise[k] = self._resume, True
        return ActOutput(actions, advise=advise)

    @staticmethod
    def _n_actions(published: dict[str, Any]) -> int:
        return int(next(v for k, v in published.items() if k != "agents").shape[1])
