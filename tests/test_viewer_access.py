"""Who may talk to the viewer: Host names (DNS rebinding), WebSocket origins, and the command token.

The attack these tests replay: a page on any site, open in the user's browser, connects to
``ws://127.0.0.1:8750/ws`` (or reaches the server under its own name after DNS rebinding) and sends
stack commands to a live simulation started with ``--allow-commands``.
"""

from __future__ import annotations

import asyncio
import json

import aiohttp
import pytest
from hypothesis import given
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.viewer.frames import RunReplay
from aamsim.viewer.live import LiveViewer
from aamsim.viewer.server import AccessPolicy, ControlError, ReplaySource, ViewerApp, parse_control, start_site
from tests.test_viewer_frames import run_dir  # noqa: F401  (fixture)


def _live_with_commands() -> tuple[Simulation, LiveViewer]:
    sim = Simulation(seed=1)
    sim.stack("CRE P1 EC35 40.0 -74.0 90 500 40")
    live = LiveViewer("127.0.0.1", 0, allow_commands=True)
    live.start()
    live.attach(sim, None)
    return sim, live


async def _first_reply(url: str, headers: dict[str, str] | None = None, line: str = "ALT P1 1500") -> dict:
    """Open the WebSocket at ``url``, send one stack command and return the ack or error it gets."""
    async with aiohttp.ClientSession() as http, http.ws_connect(url, headers=headers or {}) as ws:
        await ws.send_str(json.dumps({"op": "stack", "line": line}))
        while True:
            msg = await ws.receive_json(timeout=5)
            if msg["type"] in ("ack", "error"):
                return msg


async def _status_of_upgrade(url: str, headers: dict[str, str]) -> int:
    async with aiohttp.ClientSession() as http:
        try:
            async with http.ws_connect(url, headers=headers):
                return 101
        except aiohttp.WSServerHandshakeError as exc:
            return exc.status


def _token_of(page_url: str) -> str:
    assert "?token=" in page_url
    return page_url.split("?token=", 1)[1]


def test_the_page_url_carries_a_fresh_token_only_when_commands_are_allowed():
    with_commands = LiveViewer("127.0.0.1", 0, allow_commands=True)
    other = LiveViewer("127.0.0.1", 0, allow_commands=True)
    read_only = LiveViewer("127.0.0.1", 0)
    try:
        urls = [v.start() for v in (with_commands, other, read_only)]
        assert with_commands.page_url is not None and other.page_url is not None
        token = _token_of(with_commands.page_url)
        assert len(token) >= 20 and token != _token_of(other.page_url)  # one secret per run
        assert read_only.page_url == urls[2] and "token" not in urls[2]
    finally:
        for v in (with_commands, other, read_only):
            v.close()


def test_commands_need_the_token_even_from_the_viewers_own_origin():
    sim, live = _live_with_commands()
    try:
        base = live.url
        assert base is not None and live.page_url is not None
        own_origin = {"Origin": base.rstrip("/")}
        refused = asyncio.run(_first_reply(base + "ws", own_origin))
        assert refused["type"] == "error" and "token" in refused["error"]
        wrong = asyncio.run(_first_reply(base + "ws?token=guess", own_origin))
        assert wrong["type"] == "error" and "token" in wrong["error"]
        sim.run_until(2.0)
        assert sim.view.selalt[0] == pytest.approx(500 * 0.3048)  # nothing ran
        ok = asyncio.run(_first_reply(base + "ws?token=" + _token_of(live.page_url), own_origin))
        assert ok == {"type": "ack", "op": "stack", "line": "ALT P1 1500"}
        sim.run_until(4.0)
        assert sim.view.selalt[0] == pytest.approx(1500 * 0.3048)
    finally:
        live.close()


@pytest.mark.parametrize("origin", ["http://attacker.example", "http://attacker.example:8750", "null",
                                    "http://127.0.0.1:1", "https://127.0.0.1", "file://", "chrome-extension://x"])
def test_a_cross_origin_page_cannot_open_the_websocket_even_with_the_token(origin: str):
    sim, live = _live_with_commands()
    try:
        assert live.url is not None and live.page_url is not None
        url = live.url + "ws?token=" + _token_of(live.page_url)
        assert asyncio.run(_status_of_upgrade(url, {"Origin": origin})) == 403
        sim.run_until(2.0)
        assert sim.view.selalt[0] == pytest.approx(500 * 0.3048)
    finally:
        live.close()


@pytest.mark.parametrize("host", ["attacker.example", "attacker.example:8761", "127.0.0.1.attacker.example",
                                  "localhost.attacker.example:80", ""])
def test_dns_rebinding_is_refused_on_every_path(run_dir, host: str):  # noqa: F811
    async def main():
        runner, url = await start_site(ViewerApp(ReplaySource(RunReplay(run_dir))), "127.0.0.1", 0)
        try:
            async with aiohttp.ClientSession() as http:
                for path in ("/", "/api/meta", "/api/frame?t=10", "/static/viewer.js", "/ws"):
                    async with http.get(url.rstrip("/") + path, headers={"Host": host}) as res:
                        assert res.status == 403, path
                        assert "Host" in await res.text() or "Host" in res.reason
        finally:
            await runner.cleanup()

    asyncio.run(main())


@pytest.mark.parametrize("host", ["127.0.0.1:{port}", "localhost:{port}", "[::1]:{port}", "10.1.2.3:{port}",
                                  "LOCALHOST:{port}", "viewer.lab:{port}"])
def test_loopback_ip_and_declared_names_are_served(run_dir, host: str):  # noqa: F811
    async def main():
        app = ViewerApp(ReplaySource(RunReplay(run_dir)), access=AccessPolicy.for_server("127.0.0.1", ("viewer.lab",)))
        runner, url = await start_site(app, "127.0.0.1", 0)
        port = url.rstrip("/").rsplit(":", 1)[1]
        try:
            async with aiohttp.ClientSession() as http, \
                    http.get(url + "api/meta", headers={"Host": host.format(port=port)}) as res:
                assert res.status == 200
                assert (await res.json())["mode"] == "replay"
        finally:
            await runner.cleanup()

    asyncio.run(main())


def test_same_origin_replay_and_origin_less_clients_still_stream(run_dir):  # noqa: F811
    async def main():
        runner, url = await start_site(ViewerApp(ReplaySource(RunReplay(run_dir))), "127.0.0.1", 0)
        try:
            async with aiohttp.ClientSession() as http:
                for headers in ({"Origin": url.rstrip("/")}, {}):
                    async with http.ws_connect(url + "ws", headers=headers) as ws:
                        frame = await ws.receive_json(timeout=5)
                        assert frame["type"] == "frame"
        finally:
            await runner.cleanup()

    asyncio.run(main())


def test_the_bound_name_is_served_and_a_command_server_refuses_to_start_without_a_token(run_dir):  # noqa: F811
    policy = AccessPolicy.for_server("viewer.example.org")
    assert policy.host_refusal("viewer.example.org:8750") is None
    assert policy.host_refusal("other.example.org:8750") is not None
    with pytest.raises(ValueError, match="token"):
        ViewerApp(ReplaySource(RunReplay(run_dir)), allow_commands=True, access=AccessPolicy())


def test_the_token_check_refuses_before_anything_is_queued():
    with pytest.raises(ControlError, match="token"):
        parse_control(json.dumps({"op": "stack", "line": "CRE EVIL1 EC35 40 -74 0 500 40"}), "live", True,
                      token_ok=False)


@given(st.text(max_size=60))
def test_host_and_origin_checks_never_raise(text: str):
    policy = AccessPolicy.for_server(allow_commands=True)
    assert policy.host_refusal(text) is None or isinstance(policy.host_refusal(text), str)
    assert policy.origin_refusal(text, "127.0.0.1:8750") is None or isinstance(
        policy.origin_refusal(text, "127.0.0.1:8750"), str)
    assert not policy.token_matches(text) or text == policy.command_token
