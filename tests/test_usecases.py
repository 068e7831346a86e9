"""The use-case protocol: agents from creation events, a second use case through both API checkers, typed info."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

import rlbridge
from aamsim import Simulation
from aamsim.units import NM
from rlbridge.core import EpisodeCore
from rlbridge.protocol import ProtocolError, decode, encode
from rlbridge.usecases import Feedback, UseCaseBase, env_id, make_usecase
from rlbridge.usecases.reach import ReachDestination
from rlbridge.wire import step_result_from_payload, step_result_to_payload

THREE_WAY = str(Path(__file__).parent / "data" / "three_way.scn")


@pytest.fixture
def mixed_scenario(tmp_path: Path) -> Path:
    """One aircraft from CRE, two from MCRE, one from a PCALLed file, one from SCHEDULE."""
    (tmp_path / "sub.scn").write_text("00:00:05.00>CRE P1 EC35 0.2 0.2 0 1000 60\n")
    main = tmp_path / "main.scn"
    main.write_text(
        "00:00:00.00>CRE X EC35 0 0 0 1000 60\n"
        "00:00:00.00>MCRE 2 EC35 1000 60\n"
        "00:00:00.00>PCALL sub.scn\n"
        "00:00:00.00>SCHEDULE 00:00:25 CRE S1 EC35 -0.2 -0.2 0 1000 60\n"
    )
    return main


def test_possible_agents_include_mcre_pcall_schedule(mixed_scenario):
    env = rlbridge.parallel_env(str(mixed_scenario), time_limit_s=60, decision_interval_s=10.0)
    env.reset(seed=3)
    assert set(env.agents) <= set(env.possible_agents)
    ever = set(env.agents)
    while env.agents:
        obs, *_ = env.step({a: 1 for a in env.agents})
        assert set(obs) <= set(env.possible_agents) and set(env.agents) <= set(env.possible_agents)
        ever |= set(obs)
    created = {r.acid for r in env.core.sim.flight_log} | set(env.core.sim.view.ids)
    assert len(created) == 5 and {"X", "P1", "S1"} <= created
    assert ever == created
    assert set(env.possible_agents) == created  # every aircraft, however created, and nothing else
    mcre = sorted(created - {"X", "P1", "S1"})
    assert all(len(a) == 7 and a[:2].isalpha() and a[2:].isdigit() for a in mcre)
    assert env.possible_agents[0] == "X"  # the scenario's own CRE lines first, known before reset


def test_second_usecase_gymnasium_and_pettingzoo_checkers():
    gym_id = env_id("reach_destination")
    assert gym_id == "aamgym/ReachDestination-v1" and gym_id in gymnasium.registry
    env = gymnasium.make(gym_id, scenario=THREE_WAY, time_limit_s=300)
    check_env(env.unwrapped)
    obs, info = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    *_, info = env.step(2)
    assert set(info) == {"arrived", "dist_m", "simt"}
    assert isinstance(info["arrived"], bool) and isinstance(info["dist_m"], float)
    parallel_api_test(rlbridge.parallel_env(THREE_WAY, usecase="reach_destination", time_limit_s=300),
                      num_cycles=60)
    assert "aamgym/CorridorSA-v0" in gymnasium.registry


def test_reach_rewards_hand_computed():
    uc = make_usecase("reach_destination", time_penalty=0.01, arrival_bonus=5.0)
    sim = Simulation(seed=0)
    # A at 0.001 deg north of its destination (111.2 m < the 185.2 m arrival radius), B 0.1 deg away.
    sim.stack("CRE A EC35 0.001 0 180 1000 30; DEST A 0 0; CRE B EC35 0.1 0 180 1000 30; DEST B 0 0")
    sim.run_until(0.0)
    fb = uc.feedback(sim, ["A", "B"], {}, since_s=-10.0)  # a 10 s interval
    dist_a = math.radians(0.001) * 6371000.0
    assert fb.info["dist_m"][0] == pytest.approx(dist_a, rel=1e-6) and dist_a < 0.1 * NM
    assert fb.info["arrived"].tolist() == [True, False]
    assert fb.rewards.tolist() == pytest.approx([-0.1 + 5.0, -0.1])


class _WrongInfo(UseCaseBase):
    """A use case whose feedback does not match its declared info columns."""

    name = "wrong_info"
    spec = ReachDestination.spec
    info_fields = {"flag": np.bool_}  # noqa: RUF012

    def __init__(self) -> None:
        self.inner = ReachDestination()

    def observation_space(self) -> Any:
        return self.inner.observation_space()

    def action_space(self) -> Any:
        return self.inner.action_space()

    def observe(self, sim: Simulation, agents: list[str]) -> Any:
        return self.inner.observe(sim, agents)

    def apply_actions(self, sim: Simulation, actions: dict[str, Any]) -> None:
        self.inner.apply_actions(sim, actions)

    def feedback(self, sim: Simulation, agents: list[str], actions: dict[str, Any], since_s: float) -> Feedback:
        return Feedback(np.zeros(len(agents)), {"flag": np.zeros(len(agents), np.float32)})


def test_feedback_must_match_the_declared_info():
    core = EpisodeCore(THREE_WAY, _WrongInfo(), time_limit_s=100)
    core.reset(seed=0)
    with pytest.raises(ValueError, match="info column 'flag' must be a bool array"):
        core.step({})


def test_use_case_instance_and_decision_interval_from_the_protocol():
    core = EpisodeCore(THREE_WAY, make_usecase("reach_destination", decision_interval_s=7.0), time_limit_s=100)
    first = core.reset(seed=0)
    second = core.step({})
    assert second.simt - first.simt == pytest.approx(7.0)
    assert set(second.agent_info) == {"arrived", "dist_m"}
    assert core.metrics()["reach_destination"] == {"arrivals": 0, "flights_ended": 0}


def test_agent_info_and_discovered_cross_the_wire():
    core = EpisodeCore(THREE_WAY, "corridor_sa", time_limit_s=100)
    result = core.reset(seed=0)
    result = core.step({})
    back = step_result_from_payload(decode(encode({"v": 1, **step_result_to_payload(result)})))
    assert back.agents == result.agents
    assert {k: v.tolist() for k, v in back.agent_info.items()} == {k: v.tolist() for k, v in result.agent_info.items()}
    assert set(back.agent_info) == {"nmac", "lowc"} and back.discovered == result.discovered
    payload = step_result_to_payload(result)
    payload["agent_info"] = {"nmac": np.zeros(len(result.agents), np.float32)}
    with pytest.raises(ProtocolError, match="agent_info"):
        step_result_from_payload(decode(encode({"v": 1, **payload})))


def test_discovered_agents_and_typed_info_over_zmq(mixed_scenario):
    """Over ZeroMQ the same episode: possible_agents grows with MCRE/PCALL/SCHEDULE aircraft, float info intact."""
    from bridge_util import thread_server

    with thread_server(scenario_roots=(mixed_scenario.parent,)) as server:
        runs = []
        for backend, address in (("local", None), ("zmq", server.endpoint)):
            env = rlbridge.parallel_env(str(mixed_scenario), usecase="reach_destination", backend=backend,
                                        address=address, time_limit_s=60)
            trace = [env.reset(seed=3)[1]]
            assert set(env.agents) <= set(env.possible_agents)
            while env.agents:
                *_, infos = env.step({a: 2 for a in env.agents})
                assert set(infos) <= set(env.possible_agents)
                trace.append(infos)
            runs.append((list(env.possible_agents), trace))
            env.close()
    assert runs[0] == runs[1]
    possible, trace = runs[0]
    assert len(possible) == 5 and {"X", "P1", "S1"} <= set(possible)
    assert all(isinstance(i["dist_m"], float) and isinstance(i["arrived"], bool) for step in trace for i in step.values())


def test_reach_destination_counts_speed_changes_as_advisories_and_names_its_baselines():
    """Its alert rate was always 0 (it never recorded an advisory), and mvp_speed's 'hold' selected 60 kt on it."""
    from rlbridge.core import EpisodeCore

    def advisories(actions_of_step) -> int:
        core = EpisodeCore(THREE_WAY, "reach_destination", {"cruise_speed_kts": ()}, time_limit_s=300)
        result = core.reset(1)
        for k in range(6):
            result = core.step({a: actions_of_step(k) for a in result.agents})
        n = core.metrics()["operational"]["advisories"]
        core.close()
        return n

    steady, changing = advisories(lambda k: 1), advisories(lambda k: k % 2)
    assert steady == 3  # each of the three aircraft: one change (from its scenario speed to 60 kt), then repeats
    assert changing > steady
    from rlbridge.usecases.reach import ReachDestination

    assert ReachDestination.spec.baselines == ("daa",)
