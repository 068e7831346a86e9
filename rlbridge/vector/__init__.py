"""Vector environments: many episodes of a use case in one process, stepped together (docs/speed.md).

* :class:`~rlbridge.vector.single.AamVectorEnv` — a Gymnasium ``VectorEnv`` of single-agent
  episodes (``gymnasium.make_vec("aamgym/CorridorSA-v1", num_envs=N)``);
* :class:`~rlbridge.vector.multi.AamParallelVectorEnv` — N PettingZoo-style multi-agent
  episodes (the rollout workers' lockstep episodes run on it);
* :class:`~rlbridge.vector.engine.VectorEngine` — what both run on: N
  :class:`~rlbridge.core.EpisodeCore` over one :class:`~aamsim.worlds.WorldSet`.
"""

from rlbridge.vector.engine import VectorEngine
from rlbridge.vector.multi import AamParallelVectorEnv
from rlbridge.vector.single import AamVectorEnv, make_vector_env

__all__ = ["AamParallelVectorEnv", "AamVectorEnv", "VectorEngine", "make_vector_env"]
