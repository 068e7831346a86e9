"""Frozen policies acting inside a simulation: a tactical layer or a planner that is not being trained.

A policy is named by a string: a baseline of the agents' registry
(``rlbridge.agents.BASELINE_KINDS``: ``unequipped``, ``mvp_speed``, the
planners' ``no_planning`` and ``fcfs``, and any baseline added there later,
e.g. ``daa``) or the path of a training run directory or checkpoint file
(``aamgym train`` output: its best weights, acting greedily). An actor reads
the step result and a traffic snapshot of the fields it names
(``snapshot_fields``), as in a rollout; the baselines still bound to the
simulation (``reads_simulation``: ``daa``, ``mvp``, the planners) read the
:class:`SimHandle` (simulation, seed, use case) instead.

The registry is imported when a policy is built, not with this module: use
cases sit below the agents, and only a composed use case (hierarchical, or a
planner with a tactical layer) reaches up to them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.snapshots import take_snapshot
from rlbridge.usecases.protocol import Observations

if TYPE_CHECKING:
    from aamsim import Simulation

NO_POLICY = "unequipped"  # the name of "no actions at all"


@dataclass
class SimHandle:
    """What the actors read from an episode: its simulation and seed."""

    sim: Simulation
    seed: int | None = None
    usecase: Any = None


def known_baselines() -> tuple[str, ...]:
    from rlbridge.agents import BASELINE_KINDS

    return tuple(BASELINE_KINDS)


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

    @property
    def active(self) -> bool:
        return self.name != NO_POLICY

    def act(self, handle: SimHandle, agents: list[str], obs: Observations, rng: np.random.Generator) -> np.ndarray | None:
        """Actions of ``agents`` (None: no action for anyone)."""
        from rlbridge.core import StepResult

        n = len(agents)
        result = StepResult(agents, obs, np.zeros(n), np.zeros(n, bool), np.zeros(n, bool), list(agents),
                            handle.sim.simt, False)
        if handle.usecase is not self._checked:
            check = getattr(self.actor, "check_usecase", None)
            if check is not None:
                check(handle.usecase)
            self._checked = handle.usecase
        if getattr(self.actor, "reads_simulation", False):
            seen: Any = handle
        else:
            fields = tuple(getattr(self.actor, "snapshot_fields", ()))
            seen = take_snapshot(handle.sim, fields) if fields else None
        out = self.actor.act(result, seen, rng, self.explore)
        if out.actions is None:
            return None
        actions = np.asarray(out.actions, np.int64)
        if out.advise is not None:  # rows without an advisory: -1 (no action)
            actions = np.where(np.asarray(out.advise, bool), actions, -1)
        return actions


def frozen_policy(ref: str, role: str, allowed: tuple[str, ...] | None = None) -> FrozenPolicy:
    """Build the policy ``ref`` (a baseline name or a training run / checkpoint path) for ``role``.

    ``allowed`` restricts the baselines (e.g. speed advisories for a tactical
    layer); an unknown name is an error listing the known ones.
    """
    from rlbridge.agents import make_actor

    names = allowed if allowed is not None else known_baselines()
    if ref in names:
        return FrozenPolicy(ref, make_actor({"kind": ref}), {}, None, {}, None)
    path = Path(ref)
    if not (path.is_file() or (path / "checkpoints").is_dir()):
        raise ValueError(f"{role} {ref!r} is neither a known baseline ({', '.join(names)}) nor a training run "
                         "directory or checkpoint file")
    from rlbridge.experiment.evaluate import numpy_weights
    from rlbridge.experiment.train import find_checkpoint, load_checkpoint

    ckpt = load_checkpoint(find_checkpoint(path, "best"))
    algo = ckpt["algorithm"]
    actor = make_actor({"kind": algo["kind"], "config": algo["params"], "dims": ckpt["dims"]})
    actor.set_weights(numpy_weights(ckpt["learner"]["model"]))
    explore = {"greedy": True} if algo["kind"] == "d2mava" else {"epsilon": 0.0}
    env = ckpt.get("env", {})
    return FrozenPolicy(str(path), actor, explore, getattr(actor, "obs_format", None), dict(env.get("params", {})),
                        env.get("usecase"))
