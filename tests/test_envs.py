"""Environments: PettingZoo and Gymnasium conformance, agents appearing and leaving, determinism."""

from __future__ import annotations

from pathlib import Path

import gymnasium
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test, parallel_seed_test

import rlbridge

SCN = str(Path(__file__).parent / "data" / "three_way.scn")


def test_parallel_api_and_seed_tests():
    parallel_api_test(rlbridge.parallel_env(SCN, time_limit_s=600), num_cycles=100)
    parallel_api_test(rlbridge.parallel_env(SCN, time_limit_s=600, obs_format="dict"), num_cycles=100)
    parallel_seed_test(lambda: rlbridge.parallel_env(SCN, time_limit_s=300, alt_noise_ft=100), num_cycles=40)


def test_single_agent_env_checker():
    env = gymnasium.make(rlbridge.ENV_ID, scenario=SCN, time_limit_s=600)
    check_env(env.unwrapped)
    obs, info = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    obs, reward, terminated, truncated, info = env.step(2)
    assert isinstance(reward, float) and {"nmac", "lowc"} <= set(info)


def test_agents_appear_and_leave():
    env = rlbridge.parallel_env(SCN)
    obs, _ = env.reset(seed=0)
    assert env.possible_agents == ["AC1", "AC2", "AC3"]
    assert env.agents == ["AC1"]
    seen_alive, left = [], []
    while env.agents:
        prev = set(env.agents)
        obs, rew, term, trunc, info = env.step({})
        # Every agent alive before the step is reported, plus the ones that appeared.
        assert prev <= set(obs) and set(obs) == set(rew) == set(term) == set(info)
        for a in set(obs) - prev:
            assert rew[a] == 0.0 and not term[a]
        left += [a for a, t in term.items() if t]
        assert not (set(env.agents) & set(left))
        seen_alive.append(list(env.agents))
    # Each aircraft reached its destination and was deleted there (ATDIST ... DEL).
    assert sorted(left) == ["AC1", "AC2", "AC3"]
    assert seen_alive[0] == ["AC1", "AC2"]
    flights = {r.acid: r for r in env.core.sim.flight_log}
    assert all(r.arrived for r in flights.values())
    safety = env.metrics()["safety"]
    assert safety["nmac_events"] >= 1  # unequipped, the three meet


def test_nmac_flags_in_infos():
    env = rlbridge.parallel_env(SCN)
    env.reset(seed=0)
    flagged = set()
    while env.agents:
        _, _, _, _, info = env.step({})
        flagged |= {a for a, i in info.items() if i["nmac"]}
    events = [e for e in env.core.sim.services.conflicts.events if e.volume == "nmac"]
    assert flagged == {a for e in events for a in (e.ac1, e.ac2)}


def run_episode(env, seed, policy):
    obs, _ = env.reset(seed=seed)
    trace = []
    while env.agents:
        actions = {a: policy(a, k) for k, a in enumerate(env.agents)}
        obs, rew, term, trunc, info = env.step(actions)
        trace.append((sorted(obs), [obs[a].tobytes() for a in sorted(obs)], [rew[a] for a in sorted(rew)]))
    return trace, env.metrics()


def test_determinism_and_independent_envs():
    policy = lambda a, k: (hash(a) + k) % 3
    e1 = rlbridge.parallel_env(SCN, alt_noise_ft=100)
    e2 = rlbridge.parallel_env(SCN, alt_noise_ft=100)
    # Interleave two environments in one process: each must match a solo run.
    e1.reset(seed=5)
    e2.reset(seed=6)
    solo5 = run_episode(rlbridge.parallel_env(SCN, alt_noise_ft=100), 5, policy)
    both5 = run_episode(e1, 5, policy)
    both6 = run_episode(e2, 6, policy)
    again6 = run_episode(rlbridge.parallel_env(SCN, alt_noise_ft=100), 6, policy)
    assert solo5 == both5 and both6 == again6
    assert solo5[0] != both6[0]  # a different seed draws a different altitude noise


def test_bad_arguments():
    with pytest.raises(Exception, match="scenario not found"):
        rlbridge.parallel_env("no_such_file.scn")
    with pytest.raises(ValueError, match="backend"):
        rlbridge.parallel_env(SCN, backend="carrier-pigeon")
    with pytest.raises(ValueError, match="ego"):
        gymnasium.make(rlbridge.ENV_ID, scenario=SCN, ego="NOPE")


def test_a_dropped_env_is_collected():
    # Regression: functools.cache on observation_space/action_space held every env (self is in the key).
    import gc
    import weakref

    env = rlbridge.parallel_env(SCN, time_limit_s=60)
    env.reset(seed=1)
    agent = env.agents[0]
    assert env.observation_space(agent) is env.observation_space(agent)  # cached per instance
    assert env.action_space(agent) is env.action_space(agent)
    ref = weakref.ref(env)
    env.close()
    del env
    gc.collect()
    assert ref() is None
