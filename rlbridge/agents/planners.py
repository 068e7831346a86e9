"""Baselines of the strategic planning use case (``strategic_planning``, docs/usecases.md).

* :class:`NoPlanningActor` — no planning: every flight departs on schedule on its filed layer
  (what the planner does with no action at all, so ``unequipped`` is the same baseline);
* :class:`FCFSActor` — first-come-first-served strategic deconfliction, as UTM's
  operational-intent checks: requests in filed order, each flight's 4-D intent is
  reserved; a new flight takes the smallest delay, on its filed layer first and then the
  other layers from the nearest, at which its intent conflicts with no reserved intent
  (the observation's ``conflicts`` table); when no slot within the horizon is conflict-free
  it is rejected (unplaced: reported and counted).
"""

from __future__ import annotations

from typing import Any, ClassVar, cast

import numpy as np

from rlbridge.agents.rollout import ActOutput, EpisodeAccess
from rlbridge.core import StepResult
from rlbridge.usecases.protocol import DepartureSlots
from rlbridge.usecases.spec import Needs, check_fits

PLANNER = "planner"


def fcfs_action(conflicts: np.ndarray, action_mask: np.ndarray, filed_layer: int, reject: int | None) -> int:
    """The first conflict-free (delay, layer): least delay, then the filed layer, then the nearest layers.

    ``conflicts`` is (delays, layers); an action is ``delay * layers + layer``. With no
    conflict-free valid candidate: ``reject`` (or, without a reject action, the valid
    candidate with the fewest conflicts, least delay first).
    """
    n_delays, n_layers = conflicts.shape
    order = sorted(range(n_layers), key=lambda l: (abs(l - filed_layer), l))
    best: tuple[float, int] | None = None
    for d in range(n_delays):
        for layer in order:
            a = d * n_layers + layer
            if action_mask[a] <= 0:
                continue
            if conflicts[d, layer] == 0:
                return a
            if best is None or conflicts[d, layer] < best[0]:
                best = (float(conflicts[d, layer]), a)
    if reject is not None:
        return reject
    return best[1] if best is not None else 0


def _planner(core: EpisodeAccess) -> Any:
    # check_usecase refused a use case without departure slots, so it has departure_planner
    return cast(DepartureSlots, core.usecase).departure_planner()


class _PlannerBaseline:
    """A rule acting for the planner agent only (the hierarchical use case's aircraft get nothing)."""

    obs_format: str | None = None
    snapshot_fields: tuple[str, ...] = ()
    reads_simulation = True  # aamsim's services in process (rlbridge.agents.rollout.EpisodeAccess)
    needs: ClassVar[Needs] = Needs(any_of=("departure_slot",))  # a planner agent choosing departure slots
    kind: ClassVar[str] = ""

    def set_weights(self, weights: Any) -> None:
        pass

    def check_usecase(self, usecase: Any) -> None:
        """Refuse a use case whose actions are not departure slots (no planner agent), naming its kinds."""
        if usecase is not None:
            check_fits(self.needs, usecase, f"baseline {self.kind}")

    def choose(self, planner: Any) -> int:
        raise NotImplementedError

    def act(self, result: StepResult, core: EpisodeAccess, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput:
        planner = _planner(core)
        decider = planner.decider() if hasattr(planner, "decider") else PLANNER  # a planner per vertiport: its own
        mine = np.array([a == decider for a in result.agents], bool)
        actions = np.array([self.choose(planner) if m else 0 for m in mine], np.int64)
        return ActOutput(actions, advise=mine)


class NoPlanningActor(_PlannerBaseline):
    """Depart on schedule, on the filed layer."""

    kind = "no_planning"

    def choose(self, planner: Any) -> int:
        return int(planner.default_action())


class FCFSActor(_PlannerBaseline):
    """First-come-first-served strategic deconfliction (module docstring)."""

    kind = "fcfs"

    def choose(self, planner: Any) -> int:
        req = planner.current()
        if req is None:
            return 0
        conflicts, _ = planner.candidate_table()
        filed = max(planner.plan.filed_layer.get(req.key, 0), 0)
        return fcfs_action(conflicts, planner.action_mask(req), filed, planner.reject_action)
