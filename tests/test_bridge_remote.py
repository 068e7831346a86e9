"""The ZMQ backend against a real ``aamsim serve`` process: identical results, faults, signals."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import gymnasium
import pytest
from bridge_util import ROOT, assert_same, rollout, spawn_server, stop_process, write_scenario

import rlbridge
from rlbridge.client import Connection, RemoteEpisode, ServerUnavailable


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """One server for the module, serving the conflict scenario from its working directory."""
    folder = tmp_path_factory.mktemp("served")
    write_scenario(folder)
    proc, endpoint = spawn_server("--session-timeout", "2", "--plugin", "EXAMPLE", cwd=folder)
    yield endpoint, folder
    stop_process(proc)


@pytest.mark.parametrize("params", [{}, {"obs_format": "dict", "decision_interval_s": 3.0, "n_intruders": 2}])
def test_local_and_zmq_backends_give_identical_trajectories(server, params):
    endpoint, folder = server
    scenario = folder / "conflicts.scn"  # an absolute path inside the server's root
    local = rlbridge.parallel_env(scenario, **params)
    remote = rlbridge.parallel_env(scenario, backend="zmq", address=endpoint, timeout_s=20, **params)
    assert remote.possible_agents == local.possible_agents
    for seed in (3, 4):  # two episodes on the same connection
        a = rollout(local, seed=seed, steps=500, action_seed=seed)
        b = rollout(remote, seed=seed, steps=500, action_seed=seed)
        assert len(a) > 10 and not local.agents and not remote.agents
        assert_same(b, a)
        assert_same(remote.metrics(), local.metrics())
    assert local.metrics()["safety"]["nmac_events"] >= 1  # the trajectories include conflicts
    local.close()
    remote.close()


def test_remote_episode_mirrors_episode_core(server):
    endpoint, folder = server
    local = rlbridge.EpisodeCore(folder / "conflicts.scn", time_limit_s=120.0)
    remote = RemoteEpisode(endpoint, "conflicts.scn", time_limit_s=120.0, timeout_s=20)
    for attr in ("possible_agents", "parse_errors", "time_limit_s"):
        assert getattr(remote, attr) == getattr(local, attr), attr
    assert_same(remote.reset(7).__dict__["rewards"], local.reset(7).rewards)
    assert remote.agents == local.agents
    assert remote.stack("A1 SPD 40; ECHO hi") == local.stack("A1 SPD 40; ECHO hi")
    assert remote.stack("COUNTSTEPS")[0].endswith("aircraft-samples")  # --plugin EXAMPLE is loaded
    for _ in range(3):
        r, lo = remote.step({"B1": 0}), local.step({"B1": 0})
        assert_same(r.__dict__ | {"obs": r.obs.flat}, lo.__dict__ | {"obs": lo.obs.flat})
    assert_same(remote.traffic_state(), local.traffic_state())
    remote.close()
    remote.close()  # closing twice is harmless


def test_single_agent_env_over_zmq(server):
    endpoint, folder = server
    results = []
    for kwargs in ({}, {"backend": "zmq", "address": endpoint}):
        env = gymnasium.make(rlbridge.ENV_ID, scenario=str(folder / "conflicts.scn"), ego="C1", **kwargs)
        obs, info = env.reset(seed=5)
        trace = [obs]
        done = False
        while not done:
            obs, reward, term, trunc, info = env.step(2)
            trace.append((obs, reward, term, trunc, info))
            done = term or trunc
        env.close()
        results.append(trace)
    assert_same(results[1], results[0])


CLIENT = """
import sys, time
from rlbridge.client import RemoteEpisode
ep = RemoteEpisode(sys.argv[1], "conflicts.scn", timeout_s=20)
ep.reset(seed=1)
ep.step({"A1": 0})
print("MID-EPISODE", flush=True)
time.sleep(60)
"""


def sessions(endpoint: str) -> int:
    conn = Connection(endpoint, timeout_s=10)
    try:
        return conn.call("hello")["sessions"]
    finally:
        conn.close()


def test_a_client_killed_mid_episode_frees_its_session(server):
    endpoint, folder = server
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    client = subprocess.Popen([sys.executable, "-c", CLIENT, endpoint], stdout=subprocess.PIPE, text=True, env=env,
                              cwd=folder)
    other = RemoteEpisode(endpoint, "conflicts.scn", timeout_s=20)
    try:
        assert client.stdout.readline().strip() == "MID-EPISODE"
        other.reset(seed=2)
        assert sessions(endpoint) == 2  # (the module's earlier sessions were closed or have timed out)
        before = 1
        client.send_signal(signal.SIGKILL)
        client.wait(10)
        deadline = time.monotonic() + 15  # session timeout 2 s, checked every 0.1 s
        while time.monotonic() < deadline:
            other.step({})  # the other client keeps being served (and keeps its session alive)
            if sessions(endpoint) == before:
                break
            time.sleep(0.2)
        assert sessions(endpoint) == before
    finally:
        stop_process(client)
    assert other.step({}).simt > 0
    other.close()


def test_a_dead_server_raises_server_unavailable_within_the_timeout(tmp_path):
    write_scenario(tmp_path)
    proc, endpoint = spawn_server(cwd=tmp_path)
    try:
        # A live server may take minutes to answer its first requests (compiling the kernel on a loaded
        # machine, when the Numba cache is cold): the 1 s timeout under test
        # applies once the server is dead (the same connection, its timeout lowered).
        episode = RemoteEpisode(endpoint, "conflicts.scn", timeout_s=600.0)
        episode.reset(seed=1)
        episode.step({})
        episode.connection.timeout_s = 1.0
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        start = time.monotonic()
        with pytest.raises(ServerUnavailable, match=r"at tcp://127\.0\.0\.1:\d+ within 1 s to 'step'"):
            episode.step({})
        assert time.monotonic() - start < 30.0  # gave up after its 1 s (not after 600 s), with room for a loaded CPU
        with pytest.raises(RuntimeError, match="reset again"):
            episode.step({})  # the session is gone with the server
        start = time.monotonic()
        with pytest.raises(ServerUnavailable):
            episode.reset(seed=1)
        assert time.monotonic() - start < 30.0
        episode.close()
    finally:
        stop_process(proc)


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_signals_stop_the_server_cleanly(tmp_path, signum):
    write_scenario(tmp_path)
    proc, endpoint = spawn_server(cwd=tmp_path)
    try:
        episode = RemoteEpisode(endpoint, "conflicts.scn", timeout_s=10)
        episode.reset(seed=1)
        start = time.monotonic()
        proc.send_signal(signum)
        assert proc.wait(10) == 0
        assert time.monotonic() - start < 5.0
        err = proc.stderr.read()
        assert f"{signal.Signals(signum).name} received: stopping" in err and "closed" in err
        assert "Traceback" not in err
        episode.connection.timeout_s = 0.5
        with pytest.raises(ServerUnavailable):
            episode.step({})
        episode.close()
    finally:
        stop_process(proc)


def test_serve_rejects_unknown_plugins_and_bad_endpoints():
    from click.testing import CliRunner

    from aamsim.cli import main

    runner = CliRunner()
    result = runner.invoke(main, ["serve", "--bind", "tcp://127.0.0.1:*", "--plugin", "NOSUCH"])
    assert result.exit_code == 2 and "unknown plugin NOSUCH" in result.output
    result = runner.invoke(main, ["serve", "--bind", "nonsense://x"])
    assert result.exit_code == 2 and "cannot listen on nonsense://x" in result.output
    result = runner.invoke(main, ["serve", "--help"])
    assert "tcp://127.0.0.1:5555" in result.output and "--scenario-root" in result.output
