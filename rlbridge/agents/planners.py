"""Baselines of the strategic planning use case (``strategic_planning``, docs/usecases.md).

* :class:`NoPlanningActor` — no planning: every flight departs on schedule on its filed layer
  (what the planner does with no action at all, so ``unequipped`` is the same baseline);
* :class:`FCFSActor` — first-come-first-served strategic deconfliction, as UTM's
  operational-intent checks: requests in filed order, each flight's 4-D intent is
  reserved; a new flight takes the smallest delay, on its filed layer first and then the
  other layers from the nearest, at which its intent conflicts with no reserved intent
  (the observation's ``conflicts`` table); when no slot within the horizon is conflict-free
  it is rejected (unplaced: reported and counted).

Both act on the step result alone: what the use case's departure planner offers for the
request being decided is published with it (``info["departure_request"]``,
:func:`rlbridge.usecases.targets.departure_request_info`), so they run on every backend.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from aamsim.snapshots import TrafficSnapshot
from rlbridge.agents.rollout import ActOutput
from rlbridge.core import StepResult
from rlbridge.usecases.spec import Needs, check_fits
from rlbridge.usecases.targets import REQUEST_KEY


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


class _PlannerBaseline:
    """A rule acting for the planner agent only (the hierarchical use case's aircraft get nothing)."""

    obs_format: str | None = None
    snapshot_fields: tuple[str, ...] = ()  # the step result is all it reads
    needs: ClassVar[Needs] = Needs(any_of=("departure_slot",))  # a planner agent choosing departure slots
    kind: ClassVar[str] = ""

    def set_weights(self, weights: Any) -> None:
        pass

    def check_usecase(self, usecase: Any) -> None:
        """Refuse a use case whose actions are not departure slots (no planner agent), naming its kinds."""
        if usecase is not None:
            check_fits(self.needs, usecase, f"baseline {self.kind}")

    def choose(self, request: dict[str, Any]) -> int:
        raise NotImplementedError

    def act(self, result: StepResult, snapshot: TrafficSnapshot | None, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput:
        request = result.info.get(REQUEST_KEY)
        if request is None:
            raise ValueError(f"baseline {self.kind} reads the departure planner's request of the step result "
                             f"(info[{REQUEST_KEY!r}]), which the episode engine adds for use cases with "
                             "departure-slot actions")
        mine = np.array([a == request["decider"] for a in result.agents], bool)  # a planner per vertiport: its own
        actions = np.array([self.choose(request) if m else 0 for m in mine], np.int64)
        return ActOutput(actions, advise=mine)


class NoPlanningActor(_PlannerBaseline):
    """Depart on schedule, on the filed layer."""

    kind = "no_planning"

    def choose(self, request: dict[str, Any]) -> int:
        return int(request["default_action"])


class FCFSActor(_PlannerBaseline):
    """First-come-first-served strategic deconfliction (module docstring)."""

    kind = "fcfs"

    def choose(self, request: dict[str, Any]) -> int:
        if not request["pending"]:
            return 0
        reject = int(request["reject_action"])
        return fcfs_action(np.asarray(request["conflicts"]), np.asarray(request["action_mask"]),
                           int(request["filed_layer"]), None if reject < 0 else reject)
