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
from aamsim.resolution.mvp_detect import detect
from aamsim.resolution.mvp_service import mvp_commands
from rlbridge.agents.baselines import protected_zone
from rlbridge.agents.manoeuvres import MANOEUVRE_KINDS, action_targets
from rlbridge.agents.rollout import ActOutput, EpisodeAccess
from rlbridge.core import StepResult
from rlbridge.usecases.spec import Needs, check_fits


@dataclass(frozen=True)
class MVPConfig:
    """Parameters of the heading / altitude MVP baseline (distances m, times s)."""

    lookahead_s: float = 120.0  # conflict detection look-ahead (as mvp_speed)
    # Protected zone radius [m]; None: the LoWC distance of the simulation's separation standard.
    rpz_m: float | None = None
    # Vertical half-height [m]; None: the standard's NMAC distance (corridor layers are 213 m apart).
    hpz_m: float | None = None


class MVPActor:
    """Heading and altitude MVP on a use case's discrete advisories (see the module docstring)."""

    obs_format: str | None = None
    snapshot_fields: tuple[str, ...] = ()
    reads_simulation = True  # aamsim's services in process (rlbridge.agents.rollout.EpisodeAccess)
    needs: ClassVar[Needs] = Needs(any_of=MANOEUVRE_KINDS)  # heading or altitude actions

    def __init__(self, config: MVPConfig | None = None):
        self.config = config or MVPConfig()
        self.settings = MVPSettings(horizontal=False)  # heading, speed and vertical: no restriction
        self._advised: set[str] = set()
        self._episode: tuple[int | None, int] | None = None

    def set_weights(self, weights: Any) -> None:
        pass

    def check_usecase(self, usecase: Any) -> None:
        """Refuse a use case with neither heading nor altitude actions, naming its kinds."""
        if usecase is not None:
            check_fits(self.needs, usecase, "baseline mvp")

    def act(self, result: StepResult, core: EpisodeAccess, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput:
        sim, usecase = core.sim, core.usecase
        assert sim is not None
        key = (core.seed, id(sim))
        if key != self._episode:
            self._episode, self._advised = key, set()
        view = sim.view
        alive = set(result.alive)
        rows = [k for k, a in enumerate(result.agents) if a in alive and a in view]
        actions = np.zeros(len(result.agents), dtype=np.int64)
        advise = np.zeros(len(result.agents), dtype=bool)
        if not rows:
            return ActOutput(actions, advise=advise)
        c = self.config
        rpz_m, hpz_m = protected_zone(c.rpz_m, c.hpz_m, sim.separation_standard)
        conf = detect(sim, rpz_m, hpz_m, c.lookahead_s)
        coop = ~np.asarray(view.noncooperative, dtype=bool)[conf.own]
        trk, _gs, _vs, alt = mvp_commands(sim, conf, coop, self.settings, rpz_m, hpz_m, c.lookahead_s)
        in_conflict = np.zeros(view.n, dtype=bool)
        in_conflict[conf.own[coop]] = True
        names = [result.agents[k] for k in rows]
        slots = np.array([view.slot(a) for a in names], dtype=np.int64)
        targets = action_targets(usecase, sim, slots)
        for q, (k, acid, i) in enumerate(zip(rows, names, slots.tolist())):
            if in_conflict[i]:
                turn = np.abs((targets.trk[q] - trk[i] + 180.0) % 360.0 - 180.0)
                dz = np.abs(targets.alt[q] - alt[i])
                span_t = float(np.ptp(targets.trk[q])) or 1.0
                span_z = float(np.ptp(targets.alt[q])) or 1.0
                cost = turn / span_t + dz / span_z
                actions[k] = int(np.lexsort((np.arange(cost.size), cost))[0])
                advise[k] = True
                self._advised.add(acid)
            elif acid in self._advised:
                self._advised.discard(acid)
                actions[k], advise[k] = targets.resume, True
        return ActOutput(actions, advise=advise)
