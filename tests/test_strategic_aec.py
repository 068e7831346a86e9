"""Strategic planning as a PettingZoo AEC environment: one planner per vertiport, requests one at a time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pettingzoo.test import api_test

import rlbridge
from rlbridge.agents import make_actor
from rlbridge.agents.planners import fcfs_action
from rlbridge.agents.rollout import policy_input
from rlbridge.core import EpisodeCore

CROSS = str(Path(__file__).parent / "data" / "strategic_cross.scn")
NO_LAYERS = {"layers_ft": [], "max_delay_slots": 2}


def fcfs(env: rlbridge.StrategicPlanningAEC, obs: dict) -> int:
    """FCFS on the observation alone (no filed layer without layers)."""
    return fcfs_action(obs["conflicts"], obs["action_mask"], 0, env._usecase.reject_action)


def play(env: rlbridge.StrategicPlanningAEC, seed: int) -> list[tuple]:
    """One episode, every planner by FCFS: (agent, reward, observation) per turn."""
    env.reset(seed=seed)
    trace = []
    for agent in env.agent_iter():
        obs, reward, term, trunc, info = env.last()
        trace.append((agent, reward, term, trunc, {k: v.tolist() for k, v in obs.items()}, info))
        env.step(None if term or trunc else fcfs(env, obs))
    return trace


def test_aec_api_test_passes_with_a_planner_per_vertiport():
    env = rlbridge.aec_env(CROSS)
    assert env.possible_agents == ["planner_VS", "planner_VW"]  # N1, N2, N3 file ORIG VS; E1 ORIG VW
    api_test(env, num_cycles=20)
    env.close()
    with pytest.raises(ValueError, match="a planner per vertiport"):
        rlbridge.aec_env(CROSS, planners="single")


def test_each_request_goes_to_its_vertiport_planner_and_the_rewards_are_the_single_planners():
    env = rlbridge.aec_env(CROSS, **NO_LAYERS)
    env.reset(seed=1)
    turns, rewards = [], {a: 0.0 for a in env.possible_agents}
    for agent in env.agent_iter():
        obs, reward, term, trunc, _ = env.last()
        rewards[agent] += reward
        if term or trunc:
            env.step(None)
            continue
        other = [a for a in env.agents if a != agent]
        assert all(not env.observe(a)["action_mask"].any() for a in other)  # no request, no valid action
        turns.append(agent)
        env.step(fcfs(env, obs))
    # Requests in filed order: N1 (VS), E1 (VW), N2 (VS), N3 (VS).
    assert turns == ["planner_VS", "planner_VW", "planner_VS", "planner_VS"]
    sp = env.metrics()["strategic_planning"]
    assert sp["mean_delay_s"] == pytest.approx(60.0) and sp["unplaced_flights"] == ["N3"]  # the FCFS plan
    # The same engine with one planner (FCFS): the same plan, and the planners' rewards sum to its own.
    core = EpisodeCore(CROSS, "strategic_planning", NO_LAYERS)
    actor = make_actor({"kind": "fcfs"})
    result, total = core.reset(1), 0.0
    while not result.done:
        out = actor.act(result, policy_input(actor, core), np.random.default_rng(0), {})
        result = core.step({"planner": int(out.actions[0])})
        total += float(result.rewards[0])
    assert core.metrics()["strategic_planning"]["unplaced_flights"] == ["N3"]
    assert sum(rewards.values()) == pytest.approx(total, abs=1e-12)
    assert rewards["planner_VS"] < rewards["planner_VW"] <= 0.0  # VS's rejected request costs it, not VW


def test_in_process_equals_over_zmq():
    from bridge_util import thread_server

    with thread_server(scenario_roots=(Path(CROSS).parent,)) as server:
        runs = []
        for backend, address in (("local", None), ("zmq", server.endpoint)):
            env = rlbridge.aec_env(CROSS, backend=backend, address=address)
            runs.append((play(env, 4), env.metrics()))
            env.close()
    assert runs[0] == runs[1]
    assert len(runs[0][0]) >= 4
