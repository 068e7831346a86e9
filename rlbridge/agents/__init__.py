"""Reference algorithms and baselines for the AAM-Gym use cases.

========================  =====================================================================
module                    contents
========================  =====================================================================
``agents.core``           GAE, (D)DQN targets, PPO clipped loss, masked attention, schedules
``agents.rollout``        :class:`RolloutWorker` (in-process or Ray actor), episode batches
``agents.ddqn``           DQN / Double DQN (parameter-shared Q-network, replay memory)
``agents.d2mava``         D2MAV-A (PPO + attention over intruders, shared or separate layers)
``agents.baselines``      unequipped aircraft, speed-only MVP conflict resolution
========================  =====================================================================

An *actor spec* ``{"kind": ..., "config": {...}, "dims": {...}}`` is all a worker needs to
rebuild the acting half of an algorithm (it crosses process boundaries as plain data).
"""

from __future__ import annotations

from typing import Any

from rlbridge.usecases.registry import make_usecase

LEARNER_KINDS = ("d2mava", "dqn")
BASELINE_KINDS = ("unequipped", "mvp_speed")


def usecase_dims(usecase: str, params: dict[str, Any]) -> dict[str, int]:
    """Observation and action sizes of a corridor-style use case (flat and dict formats)."""
    p = {k: v for k, v in params.items() if k != "obs_format"}
    flat: Any = make_usecase(usecase, **p, obs_format="flat")
    parts: Any = make_usecase(usecase, **p, obs_format="dict").observation_space()
    n_intr, intr_dim = parts["intruders"].shape
    return {"flat_dim": int(flat.observation_space().shape[0]), "own_dim": int(parts["ownship"].shape[0]),
            "intruder_dim": int(intr_dim), "n_intruders": int(n_intr), "n_actions": int(flat.action_space().n)}


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
    raise KeyError(f"unknown actor kind {kind!r}; known: {', '.join(LEARNER_KINDS + BASELINE_KINDS)}")


def make_learner(kind: str, config: dict[str, Any], dims: dict[str, Any], device: str = "cpu",
                 seed: int = 0) -> Any:
    """Build a learner (``d2mava`` or ``dqn``) from its hyper-parameters (unknown keys are an error)."""
    if kind == "d2mava":
        from rlbridge.agents.d2mava import D2MAVALearner

        return D2MAVALearner(config, dims, device, seed)
    if kind == "dqn":
        from rlbridge.agents.ddqn import DDQNLearner

        return DDQNLearner(config, dims, device, seed)
    raise KeyError(f"unknown learner kind {kind!r}; known: {', '.join(LEARNER_KINDS)}")


__all__ = ["BASELINE_KINDS", "LEARNER_KINDS", "make_actor", "make_learner", "usecase_dims"]
