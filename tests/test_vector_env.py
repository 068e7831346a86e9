"""The native vector environments (rlbridge.vector): N sub-environments in one process give exactly what N
separate environments give with the same seeds, with Gymnasium 1.x autoreset; bad input is a clear error."""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import rlbridge
import rlbridge.core
from aamsim.threads import available_cores
from rlbridge.policies import make_usecase_with_policies
from rlbridge.vector import AamParallelVectorEnv, AamVectorEnv

# Short flights among each other, departures over a minute: episodes end (arrival, time limit) within a
# few hundred decisions, so that autoreset happens many times in a short test.
VERTIPORTS = ((40.700, -74.010), (40.715, -73.985), (40.735, -74.005), (40.725, -73.975), (40.705, -73.970))


def short_flights(path: Path, n: int = 8, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    lines = []
    for k in range(n):
        o, d = rng.choice(len(VERTIPORTS), 2, replace=False)
        (la0, lo0), (la1, lo1) = VERTIPORTS[o], VERTIPORTS[d]
        stamp = f"00:00:{int(rng.integers(0, 60)):02d}.00>"
        lines += [f"{stamp}CRE V{k} EC35 {la0} {lo0} 0 {rng.integers(9, 13) * 100} 0",
                  f"{stamp}ADDWPT V{k} {la1} {lo1}", f"{stamp}VNAV V{k} OFF", f"{stamp}SPD V{k} 90",
                  f"{stamp}V{k} ATDIST {la1} {lo1} 0.05 DEL V{k}"]
    lines.sort(key=lambda line: line[:12])  # by time; a flight's lines keep their order
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def scn(tmp_path_factory) -> str:
    return str(short_flights(tmp_path_factory.mktemp("vector") / "short.scn"))


def _compare(env_id: str, scenario: str, n: int, steps: int, mode: AutoresetMode = AutoresetMode.NEXT_STEP,
             seed: int = 3, **kwargs) -> int:
    """Step the native vector env and SyncVectorEnv of separate envs side by side; returns episode ends."""
    kwargs = {"scenario": scenario, "decision_interval_s": 1.0, "time_limit_s": 150.0, **kwargs}
    native = gymnasium.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                                autoreset_mode=mode, **kwargs)
    sync = gymnasium.make_vec(env_id, num_envs=n, vectorization_mode="sync", vector_kwargs={"autoreset_mode": mode},
                              **kwargs)
    assert isinstance(native.unwrapped, AamVectorEnv) and native.metadata["autoreset_mode"] == mode
    assert native.single_observation_space == sync.single_observation_space
    assert native.action_space == sync.action_space
    obs_a, info_a = native.reset(seed=seed)
    obs_b, info_b = sync.reset(seed=seed)
    _same(obs_a, obs_b)
    _same(info_a, info_b)
    rng = np.random.default_rng(seed)
    ends = 0
    for _ in range(steps):
        actions = rng.integers(0, native.single_action_space.n, n)
        a, b = native.step(actions), sync.step(actions)
        for x, y in zip(a, b):
            _same(x, y)
        ends += int(np.sum(a[2] | a[3]))
    native.close()
    sync.close()
    return ends


def _same(a, b) -> None:
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            _same(a[key], b[key])
    elif isinstance(a, np.ndarray) and a.dtype == object:
        assert a.shape == b.shape
        for x, y in zip(a, b):
            _same(x, y)
    else:
        assert np.array_equal(a, b), (a, b)


def test_vector_corridor_v1_equals_separate_envs_with_next_step_autoreset(scn):
    ends = _compare("aamgym/CorridorSA-v1", scn, 4, 260)
    assert ends >= 6  # sub-episodes ended and were reset while the others went on


def test_vector_same_step_autoreset_dict_observations_and_v0(scn):
    assert _compare("aamgym/CorridorSA-v1", scn, 3, 160, AutoresetMode.SAME_STEP, obs_format="dict") >= 3
    assert _compare("aamgym/CorridorSA-v0", scn, 3, 220, seed=11) >= 2


def test_vector_reach_destination_v1_equals_separate_envs(scn):
    assert _compare("aamgym/ReachDestination-v1", scn, 3, 200, seed=5) >= 3


def test_vector_on_the_shipped_scenario_draws_the_egos_of_separate_envs():
    env = gymnasium.make_vec("aamgym/CorridorSA-v1", num_envs=3, decision_interval_s=1.0)
    env.reset(seed=7)
    singles = []
    for k in range(3):
        single = gymnasium.make("aamgym/CorridorSA-v1", decision_interval_s=1.0)
        single.reset(seed=7 + k)
        singles.append(single.unwrapped.ego)
    assert env.unwrapped.egos == singles and len(set(singles)) == 3


def test_an_ended_sub_episode_never_stalls_the_others(scn):
    env = AamVectorEnv(2, scenario=scn, decision_interval_s=1.0, time_limit_s=150.0)
    _, info = env.reset(seed=0)
    t = info["simt"].copy()
    ended = np.zeros(2, bool)
    for _ in range(400):
        _, _, term, trunc, info = env.step(np.array([1, 1]))
        # Each sub-environment that did not just start again advanced one decision interval.
        went_on = info["simt"] == t + 1.0
        assert np.all(went_on | (info["simt"] <= t) | ended)
        ended = term | trunc
        t = info["simt"].copy()
        if ended.any() and not ended.all():
            break
    else:
        pytest.fail("no sub-episode ended alone")
    _, _, _, _, info2 = env.step(np.array([1, 1]))
    live = int(np.flatnonzero(~ended)[0])
    assert info2["simt"][live] == t[live] + 1.0  # the other went on in the step that reset the ended one


def test_bad_input_is_one_clear_error_each(scn, monkeypatch):
    with pytest.raises(ValueError, match="num_envs must be a whole number >= 1"):
        gymnasium.make_vec("aamgym/CorridorSA-v1", num_envs=0, scenario=scn)
    with pytest.raises(ValueError, match="2 scenarios for 3 sub-environments"):
        AamVectorEnv(3, scenario=[scn, scn])
    with pytest.raises(ValueError, match=f"between 1 and {available_cores()}, the CPU cores"):
        AamVectorEnv(2, scenario=scn, threads=available_cores() + 1)
    with pytest.raises(ValueError, match="backend 'local'"):
        AamVectorEnv(2, scenario=scn, backend="zmq")
    # Sub-environments get one space: a use case whose space came out different for one of them (here its
    # second instance, through the registry) is refused, naming the sub-environment and its scenario.
    made = []

    def second_differs(name, **params):
        made.append(name)
        return make_usecase_with_policies(name, **(dict(params, n_intruders=3) if len(made) == 2 else params))

    monkeypatch.setattr(rlbridge.core, "make_usecase_with_policies", second_differs)
    with pytest.raises(ValueError, match=r"sub-environment 1 \(scenario .*short.scn\) has Box"):
        AamVectorEnv(2, scenario=[scn, scn])


def test_parallel_vector_env_equals_separate_parallel_envs(scn):
    n = 3
    vec = AamParallelVectorEnv(n, scenario=scn, decision_interval_s=1.0, time_limit_s=120.0)
    singles = [rlbridge.parallel_env(scn, decision_interval_s=1.0, time_limit_s=120.0) for _ in range(n)]
    obs, infos = vec.reset(seed=4)
    for k, env in enumerate(singles):
        o, i = env.reset(seed=4 + k)
        _same(obs[k], o)
        _same(infos[k], i)
    rng = np.random.default_rng(0)
    steps = 0
    while any(vec.agents):
        actions = [{a: int(rng.integers(3)) for a in agents} for agents in vec.agents]
        out = vec.step(actions)
        for k, env in enumerate(singles):
            if env.agents:
                for x, y in zip(out, env.step(actions[k])):
                    _same(x[k], y)
            else:
                assert all(part[k] == {} for part in out)
        steps += 1
    assert steps > 50 and [s.possible_agents for s in singles] == vec.possible_agents
    assert vec.metrics(1) == singles[1].metrics()


@pytest.mark.parametrize("env_id", ["aamgym/CorridorSA-v1", "aamgym/ReachDestination-v1", "aamgym/HeadingAltitudeSA-v1"])
def test_single_env_observes_only_its_ego_and_gives_what_observing_everyone_gives(scn, env_id):
    """Without a traffic policy a single-agent env observes and rewards its ego alone at each step; with a
    policy that never acts it observes every agent (the policy reads their observations). The ego's
    episodes are the same bit for bit, across episode ends and resets."""
    asked: list[tuple[str, tuple[int, ...]]] = []

    def idle(agent: str, obs: np.ndarray) -> None:
        asked.append((agent, np.asarray(obs).shape))

    kwargs = {"scenario": scn, "decision_interval_s": 1.0, "time_limit_s": 150.0}
    ego_only = gymnasium.make(env_id, **kwargs)
    everyone = gymnasium.make(env_id, traffic_policy=idle, **kwargs)
    for x, y in zip(ego_only.reset(seed=4), everyone.reset(seed=4)):
        _same(x, y)
    ego = ego_only.unwrapped.ego
    assert ego_only.unwrapped._multi.core.watch == (ego,) and everyone.unwrapped._multi.core.watch is None
    rng = np.random.default_rng(4)
    ends = 0
    for _ in range(500):
        action = int(rng.integers(0, ego_only.action_space.n))
        a, b = ego_only.step(action), everyone.step(action)
        for x, y in zip(a, b):
            _same(x, y)
        if a[2] or a[3]:
            ends += 1
            for x, y in zip(ego_only.reset(), everyone.reset()):
                _same(x, y)
    assert ends >= 3
    # The policy was asked about the other agents, with their observations.
    assert {agent for agent, _ in asked} - {ego} and {shape for _, shape in asked} == {ego_only.observation_space.shape}


@pytest.mark.parametrize("agents_only", [True, False])
def test_single_env_checks_conflicts_from_its_ego_on_when_the_use_case_reads_only_its_agents(scn, monkeypatch,
                                                                                            agents_only):
    """A single-agent reset flies the traffic to the drawn ego without conflict checks when the use case's
    feedback reads only its agents' separation events (``conflicts_of_agents_only``); with the flag off
    every check runs. The checks come back before the ego's first decision (the episodes are the same:
    the test above)."""
    from aamsim.conflicts.service import ConflictService
    from rlbridge.usecases.corridor import CorridorSA

    monkeypatch.setattr(CorridorSA, "conflicts_of_agents_only", agents_only)
    checked: list[float] = []
    check = ConflictService._check

    def timed(self, sim):
        checked.append(sim.simt)
        return check(self, sim)

    monkeypatch.setattr(ConflictService, "_check", timed)
    flown_from: list[float] = []  # where the reset began to fly to the ego (its first decision with agents)
    until_alive = rlbridge.core.EpisodeCore.until_alive_steps

    def recorded(self, agent):
        flown_from.append(self.sim.simt)
        return (yield from until_alive(self, agent))

    monkeypatch.setattr(rlbridge.core.EpisodeCore, "until_alive_steps", recorded)
    env = gymnasium.make("aamgym/CorridorSA-v1", scenario=scn, decision_interval_s=10.0, time_limit_s=150.0)
    seen = 0
    for seed in range(8):
        checked.clear()
        flown_from.clear()
        env.reset(seed=seed)
        sim = env.unwrapped._multi.core.sim
        born = float(sim.view.created_s[sim.slot(env.unwrapped.ego)])
        assert not sim.services.conflicts.paused
        if not flown_from or born - flown_from[0] < 2.0:
            continue  # the ego was there at the first decision, or came within a second: nothing left out
        seen += 1
        between = [t for t in checked if flown_from[0] < t <= born]
        assert (between == []) if agents_only else (len(between) >= int(born - flown_from[0]) - 1)
        assert [t for t in checked if t > born]  # checked from the ego's creation to its first decision
    assert seen >= 2


def test_a_traffic_policy_set_after_the_reset_drives_the_others_from_the_next_step(scn):
    env = gymnasium.make("aamgym/CorridorSA-v1", scenario=scn, decision_interval_s=1.0, time_limit_s=150.0)
    env.reset(seed=4)
    for _ in range(5):
        env.step(1)  # hold: no advisory anywhere
    assert env.unwrapped._multi.metrics()["operational"]["advisories"] == 0
    driven: set[str] = set()

    def accelerate(agent: str, obs: np.ndarray) -> int:
        driven.add(agent)
        return 2

    env.unwrapped.traffic_policy = accelerate
    for _ in range(10):
        env.step(1)
    assert driven and env.unwrapped.ego not in driven
    assert env.unwrapped._multi.metrics()["operational"]["advisories"] > 0  # theirs: the ego held
