"""Frozen policies by name, injected into the use cases that fly one (a tactical layer, a frozen planner).

The use cases name their frozen policies by string (``tactical="mvp_speed"``, a
training run directory, ...) but sit below the agents and the experiment layer:
:class:`RegistryPolicies` is the :class:`~rlbridge.usecases.frozen.PolicySource`
that turns a name into a policy (an actor of :func:`rlbridge.agents.make_actor`, with
a checkpoint's weights for a training run), and :func:`make_usecase_with_policies`
builds a use case with it injected. The episode engine (:class:`rlbridge.core.EpisodeCore`),
the environments and the experiment layer build use cases this way.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rlbridge.usecases.frozen import FrozenPolicy
from rlbridge.usecases.registry import UseCase, make_usecase, usecase_class
from rlbridge.usecases.spec import spec_of


class RegistryPolicies:
    """The agents' baselines and ``aamgym train`` runs as frozen policies (stateless)."""

    def baselines(self) -> tuple[str, ...]:
        from rlbridge.agents import BASELINE_KINDS

        return tuple(BASELINE_KINDS)

    def __call__(self, ref: str, role: str, allowed: tuple[str, ...] | None = None) -> FrozenPolicy:
        """Build ``ref`` (a baseline name or a training run / checkpoint path) for ``role``.

        ``allowed`` restricts the baselines (e.g. speed advisories for a tactical
        layer); an unknown name is an error listing the known ones.
        """
        from rlbridge.agents import make_actor

        names = allowed if allowed is not None else self.baselines()
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
        return FrozenPolicy(str(path), actor, explore, getattr(actor, "obs_format", None),
                            dict(env.get("params", {})), env.get("usecase"))


def make_usecase_with_policies(usecase: str | type, **params: Any) -> UseCase:
    """:func:`rlbridge.usecases.registry.make_usecase`, with :class:`RegistryPolicies` injected where the use
    case flies frozen policies (its ``policy_params``)."""
    cls = usecase if isinstance(usecase, type) else usecase_class(usecase)
    if spec_of(cls).policy_params:
        return make_usecase(usecase, policies=RegistryPolicies(), **params)
    return make_usecase(usecase, **params)


__all__ = ["RegistryPolicies", "make_usecase_with_policies"]
