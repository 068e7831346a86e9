"""Helpers for bluesky-gym's environments (any BlueSky: the real one, or aamsim's after ``install()``).

bluesky-gym 0.2.0 draws each episode's scenario from numpy's and Python's
*global* random generators, not from ``env.np_random``, and DescentEnv and
PlanWaypointEnv create their aircraft in ``reset()`` without removing the
previous episode's (after a truncation it is still there, and BlueSky refuses
the second aircraft of the same callsign). So ``reset(seed=s)`` does not
reproduce an episode, on BlueSky or on aamsim, and Gymnasium's ``check_env``
rejects the environments. :class:`SeededEpisodes` closes both gaps without
changing the environments' code.
"""

from __future__ import annotations

import importlib
import random
from typing import Any

import gymnasium as gym
import numpy as np

ENV_IDS = ("DescentEnv-v0", "PlanWaypointEnv-v0", "HorizontalCREnv-v0", "VerticalCREnv-v0", "SectorCREnv-v0",
           "StaticObstacleEnv-v0", "MergeEnv-v0")


class SeededEpisodes(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """``reset(seed=s)`` seeds the global generators with ``s`` and starts from no traffic.

    The aircraft of the previous episode are removed with ``bluesky.traf.reset()``
    (of whichever ``bluesky`` the environment imported) before the environment's
    own reset; the simulation time, its step (``DT``) and the areas stay, as they
    do between bluesky-gym's episodes. Without a seed, reset only removes the traffic.
    """

    def __init__(self, env: gym.Env) -> None:
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        if seed is not None:
            random.seed(seed)
            np.random.seed(seed)
        importlib.import_module("bluesky").traf.reset()
        return self.env.reset(seed=seed, options=options)
