"""rlbridge: AAM use cases as Gymnasium, PettingZoo and RLlib environments (AAM-Gym).

    import rlbridge, gymnasium
    env = rlbridge.parallel_env(scenario="nyc_train_100.scn")       # PettingZoo ParallelEnv
    env = gymnasium.make("aamgym/CorridorSA-v1", scenario="...")   # single aircraft (registered on import)
    env = gymnasium.make("aamgym/ReachDestination-v1", scenario="...")  # every use case has its id
    env = gymnasium.make("aamgym/CorridorSA-v0", scenario="...")   # the same on fixed traffic (results made before v1)
    envs = gymnasium.make_vec("aamgym/CorridorSA-v1", num_envs=16)   # 16 in one process (rlbridge.vector)
    env = rlbridge.aec_env(scenario="nyc_train_100.scn")            # PettingZoo AEC: a departure planner per vertiport
"""

from __future__ import annotations

import gymnasium

from aamsim import __version__ as aamsim_version
from rlbridge.aec import StrategicPlanningAEC, aec_env
from rlbridge.core import EpisodeCore, StepResult
from rlbridge.envs import AamParallelEnv, AamSingleAgentEnv, CorridorSAEnv, parallel_env
from rlbridge.usecases.registry import BUILTIN_USECASES, env_id

__version__ = aamsim_version  # one version for the distribution (aamsim/__init__.py; CHANGELOG.md)
ENV_ID = "aamgym/CorridorSA-v1"


def register_env(usecase: str) -> str:
    """Register ``aamgym/<Name>-v1`` (single agent, episode variation from the reset seed) and
    ``aamgym/<Name>-v0`` (the same on fixed traffic: the use case's ``fixed_traffic`` parameters and
    the first agent as the ego) for a use case; returns the current id (idempotent)."""
    from rlbridge.usecases.registry import usecase_class

    cls = usecase_class(usecase)
    entry = "rlbridge.envs:CorridorSAEnv" if usecase == "corridor_sa" else "rlbridge.envs:AamSingleAgentEnv"
    # gymnasium.make_vec builds the native vector environment (N episodes in one process, one kernel call
    # per batch for all: rlbridge.vector); vectorization_mode="sync" still gives SyncVectorEnv.
    vector = "rlbridge.vector.single:make_vector_env"
    current = env_id(usecase)
    fixed = env_id(usecase, 0)
    if current not in gymnasium.registry:
        gymnasium.register(id=current, entry_point=entry, vector_entry_point=vector, kwargs={"usecase": usecase},
                           disable_env_checker=False)
    if fixed != current and fixed not in gymnasium.registry:
        kwargs = {"usecase": usecase, "draw_ego": False, **getattr(cls, "fixed_traffic", {})}
        gymnasium.register(id=fixed, entry_point=entry, vector_entry_point=vector, kwargs=kwargs,
                           disable_env_checker=False)
    return current


# Gymnasium's registry is where gymnasium.make looks; registering here (once) is the
# Gymnasium convention for third-party environments.
for _name in BUILTIN_USECASES:
    register_env(_name)

__all__ = ["ENV_ID", "AamParallelEnv", "AamSingleAgentEnv", "CorridorSAEnv", "EpisodeCore", "StepResult",
           "StrategicPlanningAEC", "aec_env", "parallel_env", "register_env"]
