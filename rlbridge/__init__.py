"""rlbridge: AAM use cases as Gymnasium, PettingZoo and RLlib environments (AAM-Gym).

    import rlbridge, gymnasium
    env = rlbridge.parallel_env(scenario="nyc_train_100.scn")       # PettingZoo ParallelEnv
    env = gymnasium.make("aamgym/CorridorSA-v0", scenario="...")   # single aircraft (registered on import)
"""

from __future__ import annotations

import gymnasium

from rlbridge.core import EpisodeCore, StepResult
from rlbridge.envs import AamParallelEnv, CorridorSAEnv, parallel_env

__version__ = "0.1.0"
ENV_ID = "aamgym/CorridorSA-v0"

# Gymnasium's registry is where gymnasium.make looks; registering here (once) is the
# Gymnasium convention for third-party environments.
if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="rlbridge.envs:CorridorSAEnv", disable_env_checker=False)

__all__ = ["ENV_ID", "AamParallelEnv", "CorridorSAEnv", "EpisodeCore", "StepResult", "parallel_env"]
