"""rlbridge: AAM use cases as Gymnasium, PettingZoo and RLlib environments (AAM-Gym).

    import rlbridge, gymnasium
    env = rlbridge.parallel_env(scenario="nyc_train_100.scn")       # PettingZoo ParallelEnv
    env = gymnasium.make("aamgym/CorridorSA-v0", scenario="...")   # single aircraft (registered on import)
    env = gymnasium.make("aamgym/ReachDestination-v0", scenario="...")  # every use case has its id
"""

from __future__ import annotations

import gymnasium

from aamsim import __version__ as aamsim_version
from rlbridge.core import EpisodeCore, StepResult
from rlbridge.envs import AamParallelEnv, AamSingleAgentEnv, CorridorSAEnv, parallel_env
from rlbridge.usecases.registry import BUILTIN_USECASES, env_id

__version__ = aamsim_version  # one version for the distribution (aamsim/__init__.py; CHANGELOG.md)
ENV_ID = "aamgym/CorridorSA-v0"


def register_env(usecase: str) -> str:
    """Register ``aamgym/<Name>-v0`` (single agent) for a use case; returns the id (idempotent)."""
    gym_id = env_id(usecase)
    if gym_id not in gymnasium.registry:
        entry = "rlbridge.envs:CorridorSAEnv" if usecase == "corridor_sa" else "rlbridge.envs:AamSingleAgentEnv"
        gymnasium.register(id=gym_id, entry_point=entry, kwargs={"usecase": usecase}, disable_env_checker=False)
    return gym_id


# Gymnasium's registry is where gymnasium.make looks; registering here (once) is the
# Gymnasium convention for third-party environments.
for _name in BUILTIN_USECASES:
    register_env(_name)

__all__ = ["ENV_ID", "AamParallelEnv", "AamSingleAgentEnv", "CorridorSAEnv", "EpisodeCore", "StepResult",
           "parallel_env", "register_env"]
