"""Frozen policies acting inside a simulation: a tactical layer or a planner that is not being trained.

A policy is named by a string: a baseline of the agents' registry
(``rlbridge.agents.BASELINE_KINDS``: ``unequipped``, ``mvp_speed``, the
planners' ``no_planning`` and ``fcfs``, and any baseline added there later,
e.g. ``daa``) or the path of a training run directory or checkpoint file
(``aamgym train`` output: its best weights, acting greedily). An actor reads
the step result and a traffic snapshot of the fields it names
(``snapshot_fields``), as in a rollout: the planners' and DAA's inputs come with the step
result (:func:`rlbridge.usecases.targets.step_info`).

Use cases sit below the agents and the experiment layer and import neither
(tests/test_import_contract.py): the names are turned into policies by a
:class:`PolicySource` that the caller injects (``policies=`` of the composed use
cases; :func:`rlbridge.policies.make_usecase_with_policies` passes the registry's,
and the episode engines, environments and server build use cases with it).
Without one, only ``unequipped`` (no actions at all) can be named.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from aamsim.snapshots import take_snapshot
from rlbridge.usecases.protocol import Observations
from rlbridge.usecases.targets import reads_action_targets, step_info

if TYPE_CHECKING:
    from aamsim import Simulation

NO_POLICY = "unequipped"  # the name of "no actions at all"


@dataclass
class SimHandle:
    """What the actors read from an episode: its simulation and seed."""

    sim: Simulation
    seed: int | None = None
    usecase: Any = None


@dataclass
class FrozenPolicy:
    """An actor with fixed weights (or a baseline) and how to call it."""

    name: str
    actor: Any
    explore: dict[str, Any]
    obs_format: str | None  # what the actor needs from the use case ("flat", "dict", None: any)
    usecase_params: dict[str, Any]  # the parameters it was trained with ({} for baselines)
    usecase: str | None  # the use case it was trained on (None for baselines)
    _checked: Any = field(default=None, init=False, repr=False, compare=False)  # use case last checked

    @classmethod
    def none(cls) -> FrozenPolicy:
        """``unequipped``: no action for anyone (needs no policy source)."""
        return cls(NO_POLICY, None, {}, None, {}, None)

    @property
    def active(self) -> bool:
        return self.name != NO_POLICY

    def act(self, handle: SimHandle, agents: list[str], obs: Observations, rng: np.random.Generator) -> np.ndarray | None:
        """Actions of ``agents`` (None: no action for anyone)."""
        from rlbridge.core import StepResult

        if self.actor is None:
            return None

        n = len(agents)
        # The action targets only for an actor that reads them (a learner never does; they cost a computation).
        info = step_info(handle.usecase, handle.sim, agents, targets=reads_action_targets(self.actor))
        result = StepResult(agents, obs, np.zeros(n), np.zeros(n, bool), np.zeros(n, bool), list(agents),
                            handle.sim.simt, False, info=info)
        if handle.usecase is not self._checked:
            check = getattr(self.actor, "check_usecase", None)
            if check is not None:
                check(handle.usecase)
            self._checked = handle.usecase
        fields = tuple(getattr(self.actor, "snapshot_fields", ()))
        seen = take_snapshot(handle.sim, fields, handle.sim.separation_standard) if fields else None
        out = self.actor.act(result, seen, rng, self.explore)
        if out.actions is None:
            return None
        actions = np.asarray(out.actions, np.int64)
        if out.advise is not None:  # rows without an advisory: -1 (no action)
            actions = np.where(np.asarray(out.advise, bool), actions, -1)
        return actions


class PolicySource(Protocol):
    """Turns policy names into frozen policies (injected; :class:`rlbridge.policies.RegistryPolicies`)."""

    def baselines(self) -> tuple[str, ...]:
        """The baseline names it knows."""
        ...

    def __call__(self, ref: str, role: str, allowed: tuple[str, ...] | None = None) -> FrozenPolicy:
        """The policy ``ref`` (a baseline name or a training run / checkpoint path) for ``role``.

        ``allowed`` restricts the baselines; an unknown name is an error listing the known ones.
        """
        ...


def frozen_policy(ref: str, role: str, allowed: tuple[str, ...] | None, source: PolicySource | None) -> FrozenPolicy:
    """The policy ``ref`` for ``role`` from the injected ``source``; ``unequipped`` needs none."""
    if source is None:
        if ref == NO_POLICY:
            return FrozenPolicy.none()
        raise ValueError(f"{role} {ref!r}: a frozen policy other than {NO_POLICY!r} needs a policy source; build the "
                         "use case with rlbridge.policies.make_usecase_with_policies (as the episode engines, "
                         "environments and server do) or pass policies=")
    return source(ref, role, allowed)
