"""Stable-Baselines3 on the native vector environment: its ``VecEnv`` interface over :class:`AamVectorEnv`.

Stable-Baselines3 (2.x) takes its own ``VecEnv``, not Gymnasium's ``VectorEnv``::

    from stable_baselines3 import PPO
    from rlbridge.vector.sb3 import make_sb3_vec_env

    env = make_sb3_vec_env("aamgym/CorridorSA-v1", num_envs=16, decision_interval_s=1.0)
    PPO("MlpPolicy", env, n_steps=256, seed=0).learn(100_000)

The adapter follows ``stable_baselines3.common.vec_env.DummyVecEnv`` exactly (seeds
``seed + i`` at the next reset, a sub-environment that ends is reset in the same step,
its last observation in ``info["terminal_observation"]``, ``info["TimeLimit.truncated"]``),
so PPO trained on it is PPO trained on ``DummyVecEnv`` of separate environments, bit for bit
(``tests/test_vector_training.py``). Stable-Baselines3 is imported only here.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvStepReturn

from rlbridge.vector.single import AamVectorEnv


class SB3VecEnv(VecEnv):
    """Stable-Baselines3's ``VecEnv`` over an :class:`AamVectorEnv` in ``SameStep`` autoreset mode."""

    def __init__(self, env: AamVectorEnv):
        if env.autoreset_mode != AutoresetMode.SAME_STEP:
            raise ValueError("Stable-Baselines3 resets a sub-environment in the step that ends it: make the vector "
                             "environment with autoreset_mode='SameStep' (make_sb3_vec_env does)")
        self.venv = env
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        self._actions: np.ndarray | None = None

    def reset(self) -> Any:
        obs, infos = self.venv.reset(seed=list(self._seeds))
        self.reset_infos = _split(infos, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        assert self._actions is not None, "step_wait() before step_async()"
        obs, rewards, terminated, truncated, infos = self.venv.step(self._actions)
        dones = terminated | truncated
        per_env = _split(infos, self.num_envs)
        final = _split(infos.get("final_info", {}), self.num_envs)  # the ended episodes' last infos
        out: list[dict[str, Any]] = []
        for i in range(self.num_envs):
            if dones[i]:
                info = final[i]
                info["terminal_observation"] = infos["final_obs"][i]
                self.reset_infos[i] = per_env[i]
            else:
                info = per_env[i]
            info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            out.append(info)
        return obs, rewards.astype(np.float32), dones, out

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return [getattr(self.venv, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        return [getattr(self.venv, method_name)(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gymnasium.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs


def _split(infos: dict[str, Any], n: int) -> list[dict[str, Any]]:
    """Gymnasium's vector infos (arrays with ``_key`` masks) as one dict per sub-environment."""
    out: list[dict[str, Any]] = [{} for _ in range(n)]
    for key, value in infos.items():
        if key.startswith("_") or key in ("final_obs", "final_info"):
            continue
        rows = _split(value, n) if isinstance(value, dict) else None
        for i in _where(infos.get(f"_{key}"), n):
            item = rows[i] if rows is not None else value[i]
            out[i][key] = item.item() if isinstance(item, np.generic) else item
    return out


def _where(mask: np.ndarray | None, n: int) -> Iterable[int]:
    return range(n) if mask is None else np.flatnonzero(mask).tolist()


def make_sb3_vec_env(env_id: str = "aamgym/CorridorSA-v1", num_envs: int = 1, **kwargs: Any) -> SB3VecEnv:
    """``gymnasium.make_vec(env_id, num_envs, vectorization_mode="vector_entry_point", autoreset_mode="SameStep")``
    for Stable-Baselines3 (``kwargs``: the environment's)."""
    env = gymnasium.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                             autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
    assert isinstance(env.unwrapped, AamVectorEnv)
    return SB3VecEnv(env.unwrapped)
