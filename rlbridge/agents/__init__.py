"""Reference algorithms and baselines for the AAM-Gym use cases.

========================  =====================================================================
module                    contents
========================  =====================================================================
``agents.core``           GAE, (D)DQN targets, PPO clipped loss, masked attention, schedules
``agents.rollout``        :class:`RolloutWorker` (in-process or Ray actor), episode batches
``agents.ddqn``           DQN / Double DQN (parameter-shared Q-network, replay memory)
``agents.d2mava``         D2MAV-A (PPO + attention over intruders, shared or separate layers)
``agents.baselines``      unequipped aircraft, speed-only MVP conflict resolution
``agents.daa``            DO-365 / DAIDALUS detect and avoid (``baseline=daa``): speed, or heading and altitude
``agents.mvp``            heading and altitude MVP (``baseline=mvp``) for heading / altitude use cases
``agents.planners``       departure planning: no planning, FCFS strategic deconfliction
========================  =====================================================================

An *actor spec* ``{"kind": ..., "config": {...}, "dims": {...}}`` is all a worker needs to
rebuild the acting half of an algorithm (it crosses process boundaries as plain data).
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any

import gymnasium as gym

from rlbridge.policies import make_usecase_with_policies as make_usecase
from rlbridge.usecases.registry import usecase_class, usecase_spec
from rlbridge.usecases.spec import Needs, check_fits

LEARNER_KINDS = ("d2mava", "dqn")
BASELINE_KINDS = ("unequipped", "mvp_speed", "daa", "mvp", "no_planning", "fcfs")


def usecase_dims(usecase: str, params: dict[str, Any]) -> dict[str, int]:
    """Observation and action sizes of any use case, from its spaces.

    Always ``flat_dim`` (the flattened observation) and ``n_actions`` (a
    Discrete action space) or ``action_dim`` (anything else, flattened). A
    use case with an ``obs_format`` parameter and a Dict format made of
    ``ownship`` / ``intruders`` parts (the attention models' input, e.g.
    ``corridor_sa``) adds ``own_dim``, ``intruder_dim`` and ``n_intruders``.
    """
    p = {k: v for k, v in params.items() if k != "obs_format"}
    flat_uc = make_usecase(usecase, **p, obs_format="flat") if has_obs_format(usecase) else make_usecase(usecase, **p)
    act = flat_uc.action_space()
    dims = {"flat_dim": int(gym.spaces.flatdim(flat_uc.observation_space()))}
    if isinstance(act, gym.spaces.Discrete):
        dims["n_actions"] = int(act.n)
    else:
        dims["action_dim"] = int(gym.spaces.flatdim(act))
    if has_obs_format(usecase):
        parts = make_usecase(usecase, **p, obs_format="dict").observation_space()
        if isinstance(parts, gym.spaces.Dict) and {"ownship", "intruders"} <= set(parts.spaces):
            own, intr = parts.spaces["ownship"], parts.spaces["intruders"]
            assert own.shape is not None and intr.shape is not None
            dims.update(own_dim=int(own.shape[0]), intruder_dim=int(intr.shape[1]), n_intruders=int(intr.shape[0]))
    return dims


def has_obs_format(usecase: str) -> bool:
    """Whether the use case takes an ``obs_format`` parameter (flat or dict observations)."""
    return "obs_format" in {f.name for f in fields(usecase_spec(usecase).params_class)}


def make_actor(spec: dict[str, Any]) -> Any:
    """Build the acting half described by an actor spec."""
    kind = spec["kind"]
    if kind == "d2mava":
        from rlbridge.agents.d2mava import D2MAVAActor

        return D2MAVAActor(spec["config"], spec["dims"])
    if kind == "dqn":
        from rlbridge.agents.ddqn import DDQNActor

        return DDQNActor(spec["config"], spec["dims"])
    if kind == "unequipped":
        from rlbridge.agents.baselines import UnequippedActor

        return UnequippedActor()
    if kind == "mvp_speed":
        from rlbridge.agents.baselines import SpeedMVPActor, SpeedMVPConfig

        return SpeedMVPActor(SpeedMVPConfig(**spec.get("config", {})))
    if kind == "daa":
        from rlbridge.agents.daa import DAAActor, DAAPolicyConfig

        return DAAActor(DAAPolicyConfig(**spec.get("config", {})))
    if kind == "mvp":
        from rlbridge.agents.mvp import MVPActor, MVPConfig

        return MVPActor(MVPConfig(**spec.get("config", {})))
    if kind == "no_planning":
        from rlbridge.agents.planners import NoPlanningActor

        return NoPlanningActor()
    if kind == "fcfs":
        from rlbridge.agents.planners import FCFSActor

        return FCFSActor()
    raise KeyError(f"unknown actor kind {kind!r}; known: {', '.join(LEARNER_KINDS + BASELINE_KINDS)}")


def baseline_needs(kind: str) -> Needs:
    """What baseline ``kind`` needs from a use case (its actor class's ``needs``)."""
    if kind not in BASELINE_KINDS:
        raise KeyError(f"unknown baseline {kind!r}; known: {', '.join(BASELINE_KINDS)}")
    needs: Needs = type(make_actor({"kind": kind})).needs
    return needs


def check_baseline_fits(kind: str, usecase: Any) -> None:
    """Refuse baseline ``kind`` on ``usecase`` (a use case, its class, or a registry name) when it does not fit.

    Raises:
        CapabilityError: naming the use case and the capability it lacks (e.g. ``mvp_speed`` on
            ``reach_destination``, whose speed actions are fixed targets, not decelerate / hold / accelerate).
    """
    target = usecase_class(usecase) if isinstance(usecase, str) else usecase
    check_fits(baseline_needs(kind), target, f"baseline {kind}")


def learner_config_class(kind: str) -> type:
    """The hyper-parameter dataclass of a learner kind (what ``algorithm.params`` must fit)."""
    if kind == "d2mava":
        from rlbridge.agents.d2mava import D2MAVAConfig

        return D2MAVAConfig
    if kind == "dqn":
        from rlbridge.agents.ddqn import DDQNConfig

        return DDQNConfig
    raise KeyError(f"unknown learner kind {kind!r}; known: {', '.join(LEARNER_KINDS)}")


def make_learner(kind: str, config: dict[str, Any], dims: dict[str, Any], device: str = "cpu",
                 seed: int = 0, static: bool | None = None) -> Any:
    """Build a learner (``d2mava`` or ``dqn``) from its hyper-parameters (unknown keys are an error).

    ``static``: the fixed-shape update a GPU replays as a CUDA graph (same losses); None: on CUDA only.
    """
    if kind == "d2mava":
        from rlbridge.agents.d2mava import D2MAVALearner

        return D2MAVALearner(config, dims, device, seed, static)
    if kind == "dqn":
        from rlbridge.agents.ddqn import DDQNLearner

        return DDQNLearner(config, dims, device, seed, static)
    raise KeyError(f"unknown learner kind {kind!r}; known: {', '.join(LEARNER_KINDS)}")


__all__ = ["BASELINE_KINDS", "LEARNER_KINDS", "baseline_needs", "check_baseline_fits", "learner_config_class",
           "make_actor", "make_learner", "usecase_dims"]
