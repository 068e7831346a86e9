"""External algorithms on the environments: Stable-Baselines3 (single agent) and RLlib (multi-agent)."""

from __future__ import annotations

import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import rlbridge  # noqa: F401  (registers the aamgym/* Gymnasium ids)

TINY = str(Path(__file__).parent / "data" / "tiny_conflict.scn")
ROOT = Path(__file__).resolve().parent.parent


REACH_ONE = str(Path(__file__).parent / "data" / "reach_one.scn")


def _greedy_return(env: gym.Env, act) -> float:
    obs, _ = env.reset(seed=1)
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, _ = env.step(act(obs))
        total += float(reward)
        done = terminated or truncated
    return total


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["ppo", "dqn"])
def test_stable_baselines3_learns_to_fly_fast_on_the_single_agent_env(algo):
    """SB3 learns the one thing reach_destination rewards on reach_one.scn: the fast speed.

    Hand-derived bounds (reward = 1 on arrival - 0.01 per second): the aircraft starts at 60 kt
    CAS and is deleted 92.6 m (0.05 NM) short of its destination 5003.8 m north, so it flies
    4911 m. A policy that never picks 90 kt flies at most 60 kt CAS (31.33 m/s TAS at 1000 ft):
    T >= 156.8 s, return <= 1 - 1.568 = -0.568. No policy beats 90 kt (47.0 m/s TAS):
    T >= 104.5 s, return <= -0.045.
    """
    from stable_baselines3 import DQN, PPO

    env = gym.make("aamgym/ReachDestination-v0", scenario=REACH_ONE, time_limit_s=900.0, time_penalty=0.01)
    slow = _greedy_return(env, lambda obs: 1)
    assert slow == pytest.approx(-0.568, abs=0.005)  # the bound is reached: it starts at 60 kt
    if algo == "ppo":
        model = PPO("MlpPolicy", env, n_steps=256, batch_size=64, n_epochs=4, seed=0, device="cpu")
    else:
        model = DQN("MlpPolicy", env, learning_starts=200, buffer_size=5000, train_freq=4, seed=0, device="cpu",
                    exploration_fraction=0.3, target_update_interval=250)
    model.learn(total_timesteps=3000)
    learned = _greedy_return(env, lambda obs: int(model.predict(obs, deterministic=True)[0]))
    assert -0.5 < learned <= -0.045 + 1e-9
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
