"""External algorithms on the environments: Stable-Baselines3 (single agent) and RLlib (multi-agent)."""

from __future__ import annotations

import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import rlbridge

TINY = str(Path(__file__).parent / "data" / "tiny_conflict.scn")
ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["ppo", "dqn"])
def test_stable_baselines3_trains_on_the_single_agent_env(algo):
    from stable_baselines3 import DQN, PPO

    env = gym.make(rlbridge.ENV_ID, scenario=TINY, time_limit_s=600.0, n_intruders=4)
    if algo == "ppo":
        model = PPO("MlpPolicy", env, n_steps=256, batch_size=64, n_epochs=2, seed=0, device="cpu")
    else:
        model = DQN("MlpPolicy", env, learning_starts=200, buffer_size=5000, train_freq=4, seed=0, device="cpu")
    model.learn(total_timesteps=2000)
    obs, _ = env.reset(seed=1)
    action, _ = model.predict(obs, deterministic=True)
    assert env.action_space.contains(int(action))
    env.close()


def test_rllib_adapter_protocol():
    from rlbridge.rllib_env import AamMultiAgentEnv

    env = AamMultiAgentEnv({"scenario": TINY, "time_limit_s": 600.0, "n_intruders": 4})
    assert env.possible_agents == ["TA1", "TB2"]
    assert set(env.observation_spaces) == set(env.action_spaces) == set(env.possible_agents)
    obs, _ = env.reset(seed=0)
    assert set(obs) == set(env.agents) == {"TA1", "TB2"}
    done = False
    seen_terminated: set[str] = set()
    while not done:
        obs, rew, term, trunc, _ = env.step({a: 2 for a in env.agents})
        assert "__all__" in term and "__all__" in trunc
        for a in set(term) - {"__all__"}:
            assert a in obs and a in rew  # final observation and reward of leaving agents
            if term[a]:
                seen_terminated.add(a)
        assert all(env.observation_spaces[a].contains(o) for a, o in obs.items())
        done = term["__all__"] or trunc["__all__"]
    assert seen_terminated == {"TA1", "TB2"} and term["__all__"]
    # Truncation at the time limit keeps observations for bootstrapping.
    env = AamMultiAgentEnv({"scenario": TINY, "time_limit_s": 30.0, "n_intruders": 4})
    env.reset(seed=0)
    done = False
    while not done:
        obs, rew, term, trunc, _ = env.step({a: 1 for a in env.agents})
        done = term["__all__"] or trunc["__all__"]
    assert trunc["__all__"] and not term["__all__"] and set(obs) >= {a for a in trunc if a != "__all__" and trunc[a]}


@pytest.mark.slow
def test_rllib_ppo_runs_one_iteration_on_the_multi_agent_adapter():
    import ray

    from rlbridge.rllib_env import ppo_config

    ray.init(num_cpus=max(os.cpu_count() or 1, 1), include_dashboard=False,
             runtime_env={"env_vars": {"PYTHONPATH": str(ROOT)}})
    try:
        algo = ppo_config(TINY, env_runners=0, batch=128, minibatch=64, time_limit_s=600.0, n_intruders=4).build_algo()
        result = algo.train()
        runners = result["env_runners"]
        assert runners["num_env_steps_sampled_lifetime"] >= 128
        assert np.isfinite(runners["episode_return_mean"])
        algo.stop()
    finally:
        ray.shutdown()
