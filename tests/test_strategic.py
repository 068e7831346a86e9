"""Strategic flight planning: API checkers, hand-computed FCFS delays, unplaced rows, ZeroMQ, baselines."""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

import rlbridge
from aamsim.units import FT
from rlbridge.agents import make_actor
from rlbridge.agents.rollout import policy_input
from rlbridge.core import EpisodeCore
from rlbridge.policies import make_usecase_with_policies
from rlbridge.usecases import env_id, make_usecase

CROSS = str(Path(__file__).parent / "data" / "strategic_cross.scn")
NO_LAYERS = {"layers_ft": [], "max_delay_slots": 2}


def play(core: EpisodeCore, kind: str, seed: int = 1) -> list[dict]:
    """One episode with a planner baseline; the planner's info after each decision."""
    actor = make_actor({"kind": kind})
    rng = np.random.default_rng(0)
    result = core.reset(seed)
    infos = []
    while not result.done:
        out = actor.act(result, policy_input(actor, core), rng, {})
        result = core.step({} if out.actions is None else {"planner": int(out.actions[0])})
        infos.append(result.infos()[0])
    return infos


def test_gymnasium_and_pettingzoo_checkers():
    gym_id = env_id("strategic_planning")
    assert gym_id == "aamgym/StrategicPlanning-v1" and gym_id in gymnasium.registry
    env = gymnasium.make(gym_id, scenario=CROSS)
    check_env(env.unwrapped)
    obs, _ = env.reset(seed=2)
    assert isinstance(env.observation_space, gymnasium.spaces.Dict) and env.observation_space.contains(obs)
    assert env.action_space.n == 3 * 11 + 1  # 11 delays x 3 layers + reject
    flat = gymnasium.make(gym_id, scenario=CROSS, obs_format="flat")
    check_env(flat.unwrapped)
    parallel_api_test(rlbridge.parallel_env(CROSS, usecase="strategic_planning"), num_cycles=20)


def test_fcfs_delays_hand_computed_and_the_unplaceable_row_counted():
    # N1, E1, N2, N3 request 10 s; E1 crosses N1's path at the same instant, N2 and N3 fly N1's
    # path. With 60 s slots and no layer choice, FCFS gives: N1 0 s; E1 0 s conflicts with N1 (both
    # at the crossing together), 60 s clear (2.6 km apart at the closest) -> 60 s; N2 0 s is N1, 60 s
    # meets E1 at the crossing -> 120 s; N3: 0 s N1, 60 s E1, 120 s N2, no slot left -> unplaced.
    core = EpisodeCore(CROSS, "strategic_planning", NO_LAYERS)
    infos = play(core, "fcfs")
    assert [(i["delay_s"], i["unplaced"], i["intent_conflicts"]) for i in infos] == [
        (0.0, False, 0), (60.0, False, 0), (120.0, False, 0), (0.0, True, 0)]
    m = core.metrics()
    sp = m["strategic_planning"]
    assert sp["requests"] == 4 and sp["flights_planned"] == 3 and sp["unplaced"] == 1
    assert sp["unplaced_flights"] == ["N3"]
    assert sp["mean_delay_s"] == pytest.approx(60.0) and sp["max_delay_s"] == 120.0
    assert sp["p95_delay_s"] == pytest.approx(114.0)  # numpy's linear percentile of 0, 60, 120
    messages = [str(x) for x in core.sim.reporter.messages]
    assert any("strategic_cross.scn:20: warning: N3: departure request at 10 s not placed: rejected" in x
               for x in messages)
    created = {f.acid: f.created_s for f in core.sim.flight_log}
    assert created == {"N1": 10.0, "E1": 70.0, "N2": 130.0}  # released at request + delay
    assert m["safety"]["nmac_events"] == 0 and m["safety"]["lowc_events"] == 0


def test_no_planning_flies_the_schedule_and_equals_no_action():
    runs = []
    for kind in ("no_planning", "unequipped"):
        core = EpisodeCore(CROSS, "strategic_planning", NO_LAYERS)
        infos = play(core, kind)
        runs.append((infos, core.metrics()))
    assert runs[0] == runs[1]
    infos, m = runs[0]
    # Intent conflicts counted as they are accepted: E1 with N1, N2 with N1 and E1, N3 with all three.
    assert [i["intent_conflicts"] for i in infos] == [0, 1, 2, 3]
    assert m["strategic_planning"]["unplaced"] == 0 and m["strategic_planning"]["mean_delay_s"] == 0.0
    assert m["safety"]["nmac_events"] > 0  # N1, N2, N3 fly on top of each other


def test_layer_choice_when_layers_separate():
    # Layers 700 ft (213 m) apart: inside the 450 m sphere, so FCFS must delay (as above); with a
    # 200 m separation E1 keeps its slot on the next layer up and is created at 1,200 ft.
    core = EpisodeCore(CROSS, "strategic_planning", {"max_delay_slots": 2, "separation_m": 200.0,
                                                     "alt_noise_ft": 0.0})  # fixed traffic: exact altitudes
    actor = make_actor({"kind": "fcfs"})
    rng = np.random.default_rng(0)
    result = core.reset(1)
    alts: dict[str, float] = {}
    core.sim.hooks.created.add(lambda sim, i: alts.setdefault(sim.view.ids[i], float(sim.view.alt[i])),
                               name="test.alt", priority=1000)
    infos = []
    while not result.done:
        result = core.step({"planner": int(actor.act(result, policy_input(actor, core), rng, {}).actions[0])})
        infos.append(result.infos()[0])
    assert [i["delay_s"] for i in infos[:2]] == [0.0, 0.0]
    assert core.metrics()["strategic_planning"]["layer_changes"] >= 1
    assert alts["N1"] == pytest.approx(500 * FT) and alts["E1"] == pytest.approx(1200 * FT)


def test_rows_beyond_the_horizon_are_counted_not_dropped():
    core = EpisodeCore(CROSS, "strategic_planning", {**NO_LAYERS, "horizon_s": 5.0})
    result = core.reset(1)
    while not result.done:
        result = core.step({})
    sp = core.metrics()["strategic_planning"]
    assert sp["unplaced"] == 4 and sp["decided"] == 4 and sp["flights_planned"] == 0
    assert sum("no slot before the horizon (5 s)" in str(x) for x in core.sim.reporter.messages) == 4
    # A slot beyond the horizon chosen by an agent: unplaced too, and masked in its observation.
    core = EpisodeCore(CROSS, "strategic_planning", {**NO_LAYERS, "horizon_s": 75.0})
    result = core.reset(1)
    assert result.obs.parts["action_mask"][0].tolist() == [1, 1, 0, 1]  # slots 0, 1 (70 s); 2 (130 s) no
    result = core.step({"planner": 2})
    assert result.infos()[0]["unplaced"] is True


def test_bad_parameters_and_policies_name_the_known_ones():
    with pytest.raises(ValueError, match="unknown use-case parameter.*slots_s.*known:.*slot_s"):
        make_usecase("strategic_planning", slots_s=30)
    with pytest.raises(KeyError, match="unknown use case 'strategic'; available:.*strategic_planning"):
        make_usecase("strategic")
    with pytest.raises(ValueError, match="tactical layer 'dax' is neither a known baseline \\(unequipped, mvp_speed"):
        make_usecase_with_policies("strategic_planning", tactical="dax")  # the registry's source validates names
    with pytest.raises(ValueError, match="multiple of intent_grid_s"):
        make_usecase("strategic_planning", slot_s=7.0)


def test_tactical_layer_gives_speed_advisories():
    core = EpisodeCore(CROSS, "strategic_planning", {**NO_LAYERS, "tactical": "mvp_speed"})
    play(core, "no_planning")
    m = core.metrics()
    assert m["strategic_planning"]["tactical_decisions"] > 0 and m["operational"]["advisories"] > 0


def test_same_episode_in_process_and_over_zmq():
    from bridge_util import thread_server

    with thread_server(scenario_roots=(Path(CROSS).parent,)) as server:
        runs = []
        for backend, address in (("local", None), ("zmq", server.endpoint)):
            env = rlbridge.parallel_env(CROSS, usecase="strategic_planning", backend=backend, address=address,
                                        **NO_LAYERS)
            obs, _ = env.reset(seed=4)
            trace = [obs["planner"]["conflicts"].tolist()]
            for action in (0, 0, 1, 2):
                obs, rewards, terms, truncs, infos = env.step({"planner": action})
                trace.append((rewards, infos, terms, truncs))
            while env.agents:
                trace.append(env.step({"planner": 0})[1:])
            runs.append((trace, env.metrics()))
            env.close()
    assert runs[0] == runs[1]
    assert runs[0][1]["strategic_planning"]["mean_delay_s"] == pytest.approx((60 + 120) / 4)


# ---------------------------------------------------------------------------------------- hierarchical
def test_hierarchical_checkers_both_levels():
    gym_id = env_id("hierarchical")
    assert gym_id == "aamgym/Hierarchical-v1" and gym_id in gymnasium.registry
    env = gymnasium.make(gym_id, scenario=CROSS, planning=NO_LAYERS)  # the planner learns, MVP flies
    check_env(env.unwrapped)
    assert env.unwrapped.ego == "planner"
    parallel_api_test(rlbridge.parallel_env(CROSS, usecase="hierarchical", train="tactical", planner="fcfs",
                                            planning=NO_LAYERS), num_cycles=40)


def test_frozen_fcfs_planner_under_learning_aircraft_plans_as_the_planner_agent():
    # train="tactical": aircraft are the agents; the frozen FCFS planner decides each request at
    # its time, with the same delays as the planner agent played by FCFS (hand-computed above).
    core = EpisodeCore(CROSS, "hierarchical", {"train": "tactical", "planner": "fcfs", "planning": NO_LAYERS})
    result = core.reset(1)
    seen = set(result.agents)
    while not result.done:
        result = core.step({a: 1 for a in result.alive})
        seen |= set(result.agents)
    assert seen == {"N1", "E1", "N2"}
    m = core.metrics()
    h = m["hierarchical"]
    assert (h["train"], h["planner"], h["unplaced_flights"], h["max_delay_s"]) == ("tactical", "fcfs", ["N3"], 120.0)
    assert {f.acid: f.created_s for f in core.sim.flight_log} == {"N1": 10.0, "E1": 70.0, "N2": 130.0}
    assert m["operational"]["advisories"] == 0  # hold is not an advisory


def test_hierarchical_planner_with_frozen_tactical_layer_reports_both_levels():
    core = EpisodeCore(CROSS, "hierarchical", {"planning": NO_LAYERS, "tactical": "mvp_speed"})
    infos = play(core, "no_planning")
    assert len(infos) == 4
    m = core.metrics()
    assert m["hierarchical"]["tactical_decisions"] > 0 and m["operational"]["advisories"] > 0
    assert m["hierarchical"]["flights_planned"] == 4
    with pytest.raises(ValueError, match="train must be 'planner' or 'tactical'"):
        make_usecase("hierarchical", train="both")
    with pytest.raises(ValueError, match="planner 'mvp_speed' is neither a known baseline \\(unequipped, no_planning"):
        make_usecase_with_policies("hierarchical", train="tactical", planner="mvp_speed")


def test_the_planner_is_the_only_agent():
    env = rlbridge.parallel_env(CROSS, usecase="strategic_planning", **NO_LAYERS)
    env.reset(seed=0)
    steps = 0
    while env.agents:
        assert env.agents == ["planner"]
        obs, *_ = env.step({"planner": 0})
        assert set(obs) == {"planner"}
        steps += 1
    assert env.possible_agents == ["planner"] and steps == 4  # one step per request


def test_fcfs_keeps_the_new_york_training_scenario_clear():
    # The planned intents are the flights as flown: FCFS leaves no NMAC and no LoWC event
    # (no planning: 11 NMAC and 139 LoWC, the scenario as filed), at the cost of delays and rejections.
    # Fixed traffic: with the altitude noise drawn (the default) the flights no longer hold the altitudes
    # the intents were probed at.
    runs = {}
    for kind in ("no_planning", "fcfs"):
        core = EpisodeCore("nyc_train_100.scn", "strategic_planning", {"alt_noise_ft": 0.0})
        play(core, kind)
        runs[kind] = core.metrics()
    assert (runs["no_planning"]["safety"]["nmac_events"], runs["no_planning"]["safety"]["lowc_events"]) == (11, 139)
    assert (runs["fcfs"]["safety"]["nmac_events"], runs["fcfs"]["safety"]["lowc_events"]) == (0, 0)
    sp = runs["fcfs"]["strategic_planning"]
    assert sp["flights_planned"] + sp["unplaced"] == 100 and sp["intent_conflicts"] == 0
    assert sp["unplaced"] == len(sp["unplaced_flights"]) > 0 and sp["mean_delay_s"] > 0


def test_hierarchical_over_zmq_is_the_local_episode():
    from bridge_util import thread_server

    params = {"train": "tactical", "planner": "fcfs", "planning": NO_LAYERS}
    with thread_server(scenario_roots=(Path(CROSS).parent,)) as server:
        runs = []
        for backend, address in (("local", None), ("zmq", server.endpoint)):
            env = rlbridge.parallel_env(CROSS, usecase="hierarchical", backend=backend, address=address, **params)
            env.reset(seed=2)
            trace = []
            while env.agents:
                trace.append(env.step({a: 2 for a in env.agents})[1])
            runs.append((trace, env.metrics()))
            env.close()
    assert runs[0] == runs[1]
    assert runs[0][1]["hierarchical"]["unplaced_flights"] == ["N3"]


def test_the_server_loads_no_policy_file_a_client_names(tmp_path):
    from bridge_util import thread_server

    from rlbridge.client import RemoteEpisode, RemoteError

    (tmp_path / "best.pt").write_bytes(b"not a checkpoint")
    with thread_server(scenario_roots=(Path(CROSS).parent,)) as server:
        for usecase, params in (("strategic_planning", {"tactical": str(tmp_path / "best.pt")}),
                                ("hierarchical", {"train": "tactical", "planner": str(tmp_path)})):
            with pytest.raises(RemoteError, match="=.*the server loads no policy file a client names"):
                RemoteEpisode(server.endpoint, CROSS, usecase, params).reset(seed=0)
