"""The simulation server against bad input, in threads of this process (fast, no subprocess).

Every bad request gets an error reply naming the problem, and a valid request
sent afterwards still works.
"""

from __future__ import annotations

import os
import socket
import time

import msgpack
import numpy as np
import pytest
import zmq
from bridge_util import CONFLICT_SCN, assert_same, raw_socket, rollout, thread_server, write_scenario

import rlbridge
from rlbridge.client import Connection, RemoteEpisode, RemoteError, ServerUnavailable
from rlbridge.protocol import PROTOCOL_VERSION, decode, request


@pytest.fixture
def scn_dir(tmp_path, monkeypatch):
    """The server's working directory (its default scenario root), with files outside it to protect."""
    root = tmp_path / "root"
    root.mkdir()
    write_scenario(root)
    write_scenario(tmp_path, "secret.scn")
    (root / "link.scn").symlink_to(tmp_path / "secret.scn")
    (root / "notes.txt").write_text(CONFLICT_SCN)
    monkeypatch.chdir(root)
    return root


def ask(sock: zmq.Socket, frames: list) -> dict:
    sock.send_multipart(frames)
    return decode(sock.recv_multipart())


def assert_serving(sock: zmq.Socket) -> None:
    reply = ask(sock, request("hello", 99))
    assert reply["ok"] is True and reply["id"] == 99 and reply["protocol"] == PROTOCOL_VERSION


def test_bad_messages_get_error_replies_and_the_server_keeps_serving(scn_dir):
    big = np.zeros(300_000, np.float32)  # 1.2 MB: over the 1 MB limit, under the transport limit
    cases = [
        ([os.urandom(40)], "protocol", "not valid msgpack"),
        ([b"\x82\xa1v\x01"], "protocol", "not valid msgpack"),  # truncated map
        ([msgpack.packb(["v", 1])], "protocol", "header must be a map"),
        ([msgpack.packb({"v": 7, "op": "hello", "id": 3})], "version", "protocol version 7"),
        ([msgpack.packb({"v": 1, "op": "frobnicate", "id": 3})], "unknown_op", "unknown op 'frobnicate'"),
        ([msgpack.packb({"v": 1, "op": 42, "id": 3})], "protocol", "op must be a string"),
        (request("open", 3, scenario=17), "protocol", "field 'scenario' must be a string"),
        (request("open", 3), "protocol", "missing field 'scenario'"),
        (request("stack", 3, text="ECHO", extra=1), "protocol", "unknown field(s) 'extra'"),
        (request("reset", 3, seed="one"), "protocol", "field 'seed' must be an integer"),
        (request("step", 3, actions=[1, 2]), "protocol", "field 'actions' must be"),
        ([msgpack.packb({"v": 1, "op": "step", "id": 3, "actions": {"__nd__": 0, "dtype": "float32", "shape": [4]}})],
         "protocol", "has 0 buffer frame"),  # truncated: the array frame is missing
        (request("hello", 3, client=big), "too_large", "message too large"),
        (request("step", 3, actions={}), "no_session", "no open session"),
        (request("shutdown", 3), "forbidden", "shutdown is disabled"),
        # Files outside the roots are answered as missing ones (issue 26: no existence oracle).
        (request("open", 3, scenario="/etc/passwd"), "not_found", "scenario not found on the server"),
        (request("open", 3, scenario="../secret.scn"), "not_found", "scenario not found on the server"),
        (request("open", 3, scenario="link.scn"), "not_found", "scenario not found on the server"),
        (request("open", 3, scenario="notes.txt"), "not_found", "a client may open the .scn files in"),
        (request("open", 3, scenario="nowhere.scn"), "not_found", "scenario not found on the server"),
        (request("open", 3, scenario="conflicts.scn", params={"alpha": "x", "nope": 1}), "bad_request",
         "unknown use-case parameter(s) nope"),
        (request("open", 3, scenario="conflicts.scn", usecase="chess"), "bad_request", "unknown use case 'chess'"),
    ]
    with thread_server(max_message_bytes=1_000_000) as server, raw_socket(server.endpoint) as sock:
        for frames, code, fragment in cases:
            reply = ask(sock, frames)
            assert reply["ok"] is False and reply["code"] == code and fragment in reply["error"], (frames[:1], reply)
            assert reply["id"] in (3, None)
            assert_serving(sock)
        assert server.sessions == {}


def test_raw_tcp_garbage_does_not_disturb_the_server(scn_dir):
    with thread_server() as server:
        host, port = server.endpoint.removeprefix("tcp://").rsplit(":", 1)
        for payload in (os.urandom(64), b"\xff" + b"\x00" * 8 + b"\x7f" + os.urandom(300)):  # noise; a ZMTP-like greeting
            with socket.create_connection((host, int(port)), timeout=5) as raw:
                raw.sendall(payload)
        with raw_socket(server.endpoint) as sock:
            assert_serving(sock)


def test_a_frame_over_the_transport_limit_drops_only_that_connection(scn_dir):
    with thread_server(max_message_bytes=100_000) as server:
        with raw_socket(server.endpoint, timeout_ms=1000) as sock:
            sock.send_multipart(request("hello", 1, client=np.zeros(100_000, np.float32)))  # 400 kB > 2x limit
            with pytest.raises(zmq.Again):
                sock.recv_multipart()  # zmq dropped the connection: no reply can come
        with raw_socket(server.endpoint) as sock:
            assert_serving(sock)


def test_req_clients_and_errors_in_sessions(scn_dir):
    with thread_server() as server, raw_socket(server.endpoint, zmq.REQ) as req:
        opened = ask(req, request("open", 1, scenario="conflicts.scn"))
        assert opened["ok"] and opened["possible_agents"] == ["A1", "B1", "C1", "D1", "E1"]
        assert ask(req, request("step", 2, actions={}))["error"] == "step before reset"
        first = ask(req, request("reset", 3, seed=4))
        assert first["agents"] == ["A1", "B1"] and first["obs"].dtype == np.float32
        bad = ask(req, request("step", 4, agents=["A1"], actions=np.array([7])))
        assert bad["code"] == "bad_request" and "action 7 for A1 is not 0, 1 or 2" in bad["error"]
        bad = ask(req, request("step", 5, actions={"A1": "fast"}))
        assert bad["code"] == "protocol" and "action of 'A1' must be a number" in bad["error"]
        # PCALL and IC inside a remote session obey the scenario roots too.
        for text in ("PCALL /etc/passwd", "IC /etc/hostname"):
            messages = ask(req, request("stack", 6, text=text))["messages"]
            assert any("not found" in m for m in messages), messages
        state = ask(req, request("state", 7))
        assert state["ids"] == ["A1", "B1"] and state["lat"].dtype == np.float64 and state["vs"].shape == (2,)
        assert ask(req, request("close", 8))["closed"] is True
        assert server.sessions == {}


def test_reset_with_a_scenario_opens_and_sessions_are_limited(scn_dir):
    with thread_server(max_sessions=1) as server:
        one = Connection(server.endpoint, timeout_s=5)
        two = Connection(server.endpoint, timeout_s=5)
        try:
            reply = one.call("reset", scenario="conflicts", seed=1)  # .scn added, as aamsim run does
            assert reply["possible_agents"][0] == "A1" and reply["agents"] == ["A1", "B1"]
            with pytest.raises(RemoteError) as info:
                two.call("open", scenario="scn/demo.scn")
            assert info.value.code == "busy"
            one.call("close")
            assert two.call("open", scenario="scn/demo.scn")["possible_agents"] == ["UAM1", "UAM2", "UAM3"]
        finally:
            one.close()
            two.close()


def test_idle_sessions_are_freed(scn_dir):
    with thread_server(session_timeout_s=0.3, poll_interval_s=0.05) as server:
        episode = RemoteEpisode(server.endpoint, "conflicts.scn", timeout_s=5)
        episode.reset(seed=1)
        assert len(server.sessions) == 1
        deadline = time.monotonic() + 5
        while server.sessions and time.monotonic() < deadline:
            time.sleep(0.05)
        assert server.sessions == {}
        with pytest.raises(RemoteError) as info:
            episode.step({})
        assert info.value.code == "no_session"
        assert episode.reset(seed=1).agents == ["A1", "B1"]  # reset opens a new session
        episode.close()


def test_shutdown_when_enabled(scn_dir):
    with thread_server(allow_shutdown=True) as server:
        conn = Connection(server.endpoint, timeout_s=5)
        assert conn.call("shutdown")["stopping"] is True
        conn.close()
        deadline = time.monotonic() + 5
        while not server._socket.closed and time.monotonic() < deadline:
            time.sleep(0.02)
        assert server._socket.closed


def test_two_servers_and_two_local_envs_in_one_process_do_not_interfere(scn_dir):
    def make(backend: str, address: str | None, variant: int):
        params = {"decision_interval_s": 10.0} if variant == 0 else {"decision_interval_s": 5.0, "obs_format": "dict"}
        return rlbridge.parallel_env("conflicts.scn", backend=backend, address=address, timeout_s=10, **params)

    alone = [rollout(make("local", None, v), seed=10 + v, steps=12, action_seed=v) for v in (0, 1)]
    with thread_server() as s1, thread_server() as s2:
        envs = [make("local", None, 0), make("local", None, 1), make("zmq", s1.endpoint, 0), make("zmq", s2.endpoint, 1)]
        seeds = [10, 11, 10, 11]
        rngs = [np.random.default_rng(v) for v in (0, 1, 0, 1)]
        runs = [[env.reset(seed=s)] for env, s in zip(envs, seeds)]
        for _ in range(12):  # interleaved steps
            for env, rng, run in zip(envs, rngs, runs):
                if env.agents:
                    run.append(env.step({a: int(rng.integers(3)) for a in env.agents}))
        for k, run in enumerate(runs):
            assert_same(run, alone[k % 2])
        metrics = [env.metrics() for env in envs]
        assert_same(metrics[0], metrics[2])
        assert_same(metrics[1], metrics[3])
        for env in envs:
            env.close()


def test_client_of_a_missing_server_raises_within_its_timeout(scn_dir):
    ctx = zmq.Context()
    probe = ctx.socket(zmq.ROUTER)
    port = probe.bind_to_random_port("tcp://127.0.0.1")
    probe.close(0)
    ctx.term()
    start = time.monotonic()
    with pytest.raises(ServerUnavailable, match=f"127.0.0.1:{port} within 0.5 s"):
        RemoteEpisode(f"tcp://127.0.0.1:{port}", "conflicts.scn", timeout_s=0.5)
    assert time.monotonic() - start < 1.5


def test_the_raw_pyzmq_client_of_the_protocol_doc_works(scn_dir, capsys):
    import re

    from bridge_util import ROOT

    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "protocol.md").read_text(), re.DOTALL)
    with thread_server() as server:
        code = blocks[0].replace("tcp://127.0.0.1:5555", server.endpoint)
        exec(compile(code, "protocol.md", "exec"), {})  # noqa: S102 - the documented example, run as written
        assert server.sessions == {}
    out = capsys.readouterr().out
    assert "['UAM1'] (1, 339)" in out
