"""Training on the native vector environment, unchanged: Stable-Baselines3 PPO and a CleanRL-style PPO loop give
the same weights on it as on N separate environments with the same seeds (so they train on it as on those)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import torch
from test_vector_env import short_flights

import rlbridge  # noqa: F401  (registers the aamgym ids)

ENV = "aamgym/CorridorSA-v1"
KWARGS = {"decision_interval_s": 1.0, "time_limit_s": 150.0}


@pytest.fixture(scope="module")
def scn(tmp_path_factory) -> str:
    return str(short_flights(tmp_path_factory.mktemp("training") / "short.scn", seed=2))


def _weights(module: torch.nn.Module) -> list[np.ndarray]:
    return [p.detach().numpy().copy() for p in module.parameters()]


def test_sb3_ppo_trains_on_the_native_vector_env_as_on_separate_envs(scn):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from rlbridge.vector.sb3 import make_sb3_vec_env

    n = 4
    native = make_sb3_vec_env(ENV, num_envs=n, scenario=scn, **KWARGS)
    separate = DummyVecEnv([lambda: gymnasium.make(ENV, scenario=scn, **KWARGS) for _ in range(n)])
    models = []
    for env in (native, separate):
        model = PPO("MlpPolicy", env, n_steps=256, batch_size=128, n_epochs=2, seed=5, device="cpu")
        model.learn(total_timesteps=2 * 256 * n)  # 2,048 steps, several episodes per sub-environment
        models.append(model)
    a, b = (_weights(m.policy) for m in models)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not all(np.array_equal(x, y) for x, y in zip(a, _weights(PPO("MlpPolicy", native, seed=5).policy)))
    assert len(models[0].ep_info_buffer) == 0  # no Monitor on either: the episodes are the envs' own
    native.close()


def test_cleanrl_style_ppo_loop_runs_unchanged_on_the_native_vector_env(scn, monkeypatch):
    spec = importlib.util.spec_from_file_location(
        "cleanrl_ppo_vector", Path(__file__).parents[1] / "examples" / "cleanrl_ppo_vector.py")
    assert spec is not None and spec.loader is not None
    example = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, example)  # its dataclass looks its module up
    spec.loader.exec_module(example)
    results = []
    for sync in (True, False):
        envs = example.make_envs(ENV, 4, sync, scenario=scn, **KWARGS)
        agent, returns = example.train(envs, total_steps=4 * 64 * 8, seed=3)
        envs.close()
        results.append((_weights(agent), returns))
    (wa, ra), (wb, rb) = results
    assert len(ra) >= 8 and ra == rb  # the same episodes ended with the same returns
    assert all(np.array_equal(x, y) for x, y in zip(wa, wb))
