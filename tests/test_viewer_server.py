"""The viewer's server over real HTTP and WebSocket connections: read-only, bad requests answered, clients isolated."""

from __future__ import annotations

import asyncio
import json
import socket
import time

import aiohttp
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.viewer.frames import RunReplay
from aamsim.viewer.live import LiveViewer
from aamsim.viewer.server import ControlError, ReplaySource, ViewerApp, parse_control, start_site
from tests.test_viewer_frames import run_dir  # noqa: F401  (fixture)


async def _serve(app: ViewerApp):
    runner, url = await start_site(app, "127.0.0.1", 0)
    return runner, url


def _run(coro):
    return asyncio.run(coro)


def test_the_server_answers_bad_requests_with_4xx_and_a_message(run_dir):  # noqa: F811
    async def main():
        runner, url = await _serve(ViewerApp(ReplaySource(RunReplay(run_dir))))
        try:
            async with aiohttp.ClientSession() as http:
                async def get(path, method="GET"):
                    async with http.request(method, url.rstrip("/") + path) as res:
                        return res.status, await res.text()

                status, body = await get("/")
                assert status == 200 and "<canvas id=\"map\"" in body
                assert (await get("/static/viewer.js"))[0] == 200
                # nothing outside the shipped page is served, however the path is spelled
                for path in ("/static/..%2F..%2Fsetup.cfg", "/static/frames.py", "/static/%2e%2e/server.py",
                             "/summary.json", "/api/../../etc/passwd"):
                    status, body = await get(path)
                    assert status == 404, path
                    assert "settings" not in body and "import" not in body
                status, body = await get("/api/meta", "POST")
                assert status == 405 and "GET" in body
                status, body = await get("/api/frame")
                assert status == 400 and "?t=" in body
                status, body = await get("/api/frame?t=nan")
                assert status == 400 and "finite" in body
                status, body = await get("/api/frame?t=11")
                assert status == 200 and json.loads(body)["ids"] == ["A1", "A2"]
                meta = json.loads((await get("/api/meta"))[1])
                assert meta["mode"] == "replay" and meta["t_start"] == 10.0 and meta["allow_commands"] is False
                assert [v[0] for v in meta["layout"]["vertiports"]] == ["VA", "VB"]
        finally:
            await runner.cleanup()

    _run(main())


def test_a_replay_stream_obeys_seek_and_pause_and_answers_bad_messages_without_stopping(run_dir):  # noqa: F811
    async def main():
        runner, url = await _serve(ViewerApp(ReplaySource(RunReplay(run_dir))))
        try:
            async with aiohttp.ClientSession() as http, http.ws_connect(url + "ws") as ws:
                first = await ws.receive_json(timeout=5)
                assert first["type"] == "frame" and first["simt"] == 10.0 and first["reset"]
                await ws.send_str(json.dumps({"op": "pause"}))
                await ws.send_str(json.dumps({"op": "seek", "t": 11.3}))
                for bad in ("{not json", "[1, 2]", '{"op": "explode"}', '{"op": "seek", "t": "soon"}',
                            '{"op": "speed", "x": 1e9}', '{"op": "stack", "line": "DEL A1"}'):
                    await ws.send_str(bad)
                await ws.send_bytes(b"\x00\x01")
                errors, frames = [], []
                while len(errors) < 7 or not frames or frames[-1]["simt"] != 11.3:
                    msg = await ws.receive_json(timeout=5)
                    (errors if msg["type"] == "error" else frames).append(msg)
                assert any("not JSON" in e["error"] for e in errors)
                assert any("read-only" in e["error"] and "--allow-commands" in e["error"] for e in errors)
                assert any("unknown op" in e["error"] for e in errors)
                assert any("JSON text" in e["error"] for e in errors)
                paused = frames[-1]
                assert paused["playing"] is False and paused["status"] == [2, 2]  # inside the NMAC at 11.3 s
                # still paused: the next frames stay at 11.3 s
                again = await ws.receive_json(timeout=5)
                assert again["simt"] == 11.3
                # a message over the size limit closes only this connection
                await ws.send_str("x" * 10_000)
                msg = await ws.receive(timeout=5)
                while msg.type == aiohttp.WSMsgType.TEXT:
                    msg = await ws.receive(timeout=5)
                assert msg.type in (aiohttp.WSMsgType.CLOSE, aiohttp.WSMsgType.CLOSED, aiohttp.WSMsgType.CLOSING)
            async with aiohttp.ClientSession() as http, http.ws_connect(url + "ws") as ws:
                assert (await ws.receive_json(timeout=5))["type"] == "frame"
        finally:
            await runner.cleanup()

    _run(main())


def test_a_client_that_vanishes_mid_stream_stops_neither_the_simulation_nor_the_server():
    sim = Simulation(seed=1)
    sim.services.start()
    sim.stack("CRE P1 EC35 40.0 -74.0 90 500 40")
    live = LiveViewer("127.0.0.1", 0)
    url = live.start()
    try:
        live.attach(sim, None)
        host, port = url.split("//")[1].rstrip("/").split(":")
        for _ in range(3):  # a raw WebSocket upgrade, then the socket is dropped without a close frame
            s = socket.create_connection((host, int(port)))
            s.sendall(b"GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                      b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n")
            s.recv(200)
            s.close()
        sim.run_until(30.0)
        assert sim.simt == pytest.approx(30.0)
        live.finish(sim)  # the last picture, whatever the wall-clock decimation skipped

        async def receive():
            async with aiohttp.ClientSession() as http, http.ws_connect(url + "ws") as ws:
                return await ws.receive_json(timeout=5)

        frame = asyncio.run(receive())
        assert frame["ids"] == ["P1"] and frame["simt"] == pytest.approx(30.0) and frame["finished"] is True
    finally:
        live.close()


def test_stack_commands_from_the_browser_run_only_when_allowed():
    sim = Simulation(seed=1)
    sim.stack("CRE P1 EC35 40.0 -74.0 90 500 40")
    live = LiveViewer("127.0.0.1", 0, allow_commands=True)
    url = live.start()
    try:
        live.attach(sim, None)
        assert live.page_url is not None
        token = live.page_url.split("?token=")[1]  # the secret printed in the URL (tests/test_viewer_access.py)

        async def command():
            async with aiohttp.ClientSession() as http, http.ws_connect(url + "ws?token=" + token) as ws:
                await ws.send_str(json.dumps({"op": "stack", "line": "ALT P1 1500"}))
                while True:
                    msg = await ws.receive_json(timeout=5)
                    if msg["type"] == "ack":
                        return msg

        assert asyncio.run(command())["line"] == "ALT P1 1500"
        sim.run_until(1.0)  # the hook runs the command on the simulation's thread
        assert sim.view.selalt[0] == pytest.approx(1500 * 0.3048)
    finally:
        live.close()


def test_a_taken_port_is_reported():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        with pytest.raises(OSError, match="could not listen"):
            LiveViewer("127.0.0.1", s.getsockname()[1]).start()


@settings(max_examples=300, deadline=None)
@given(st.one_of(st.text(max_size=200), st.binary(max_size=200),
                 st.dictionaries(st.sampled_from(["op", "t", "x", "line"]),
                                 st.one_of(st.sampled_from(["play", "pause", "seek", "speed", "stack"]),
                                           st.floats(), st.integers(), st.text(max_size=30), st.none(),
                                           st.booleans())).map(json.dumps)),
       st.sampled_from(["replay", "live"]), st.booleans())
def test_any_control_message_is_either_understood_or_refused_with_a_message(text, mode, allow):
    try:
        msg = parse_control(text, mode, allow)
    except ControlError as exc:
        assert str(exc)
        return
    assert msg["op"] in ("play", "pause", "seek", "speed", "stack")
    if msg["op"] == "stack":
        assert allow and mode == "live" and msg["line"].strip() == msg["line"] and msg["line"]
    if msg["op"] in ("seek", "speed"):
        assert mode == "replay"


def test_the_page_and_scripts_load_nothing_from_the_internet():
    from importlib import resources

    static = resources.files("aamsim.viewer").joinpath("static")
    for name in ("index.html", "viewer.js", "viewer.css"):
        text = static.joinpath(name).read_text()
        assert "http://" not in text and "https://" not in text and "//cdn" not in text, name


def test_serve_view_shows_the_session_that_stepped(tmp_path):
    import re
    import signal
    import subprocess
    import sys
    import urllib.request

    import rlbridge

    proc = subprocess.Popen([sys.executable, "-m", "aamsim", "serve", "--bind", "tcp://127.0.0.1:*", "--view",
                             "--port", "0", "--log-level", "WARNING"], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        url = endpoint = None
        assert proc.stderr is not None and proc.stdout is not None
        for line in proc.stderr:
            m = re.search(r"viewer: (http://127\.0\.0\.1:\d+/)", line)
            if m:
                url = m.group(1)
                break
        m = re.search(r"listening on (tcp://\S+)", proc.stdout.readline())
        assert url and m
        endpoint = m.group(1)
        env = rlbridge.parallel_env("nyc_train_100.scn", backend="zmq", address=endpoint, time_limit_s=300.0)
        env.reset(seed=4)
        for _ in range(3):
            env.step({})
        time.sleep(0.15)  # past the viewer's frame period, so the next step publishes
        env.step({})
        state = env.core.traffic_state()
        with urllib.request.urlopen(url + "api/frame") as res:
            frame = json.loads(res.read())
        with urllib.request.urlopen(url + "api/meta") as res:
            meta = json.loads(res.read())
        assert frame["simt"] == pytest.approx(state["simt"]) and frame["ids"] == list(state["ids"])
        assert meta["title"] == "session 1: nyc_train_100"
        assert [v[0] for v in meta["layout"]["vertiports"]][:2] == ["NYV01", "NYV02"]
        env.close()
    finally:
        proc.send_signal(signal.SIGINT)
        assert proc.wait(20) == 0


def test_a_deeply_nested_message_gets_the_same_answer_on_any_stack():
    # Found by the viewer fuzzer: 500 nested arrays parsed in the fuzzer's process (an array, not an
    # object) but hit the recursion limit deeper in the server's stack ("not JSON").
    import sys

    deep = "[" * 500 + "]" * 500
    with pytest.raises(ControlError, match="nested deeper than 32 levels") as shallow:
        parse_control(deep, "replay", False)

    def nested(k: int) -> str:
        if k:
            return nested(k - 1)
        with pytest.raises(ControlError) as exc:
            parse_control(deep, "replay", False)
        return str(exc.value)

    assert nested(sys.getrecursionlimit() - 200) == str(shallow.value)
    # Brackets inside strings are text, not nesting.
    assert parse_control('{"op": "pause", "note": "' + "[" * 100 + '"}', "replay", False)["op"] == "pause"


@pytest.mark.parametrize("signal_name", ["SIGINT", "SIGTERM"])
def test_aamsim_view_stops_on_ctrl_c_even_when_started_with_ctrl_c_ignored(run_dir, signal_name):  # noqa: F811
    # A background job of a script (and all a CI runner starts in the background) inherits SIGINT
    # ignored; `aamsim view` then served on after Ctrl-C until killed (the browser tests hung 120 s).
    import re
    import signal
    import subprocess
    import sys

    def ignore_ctrl_c() -> None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    proc = subprocess.Popen([sys.executable, "-m", "aamsim", "view", str(run_dir), "--port", "0"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, preexec_fn=ignore_ctrl_c)
    try:
        assert proc.stderr is not None
        for line in proc.stderr:
            if re.search(r"http://127\.0\.0\.1:\d+/", line):
                break
        else:
            raise AssertionError(f"no viewer URL; exit {proc.wait(10)}")
        proc.send_signal(getattr(signal, signal_name))
        assert proc.wait(60) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
