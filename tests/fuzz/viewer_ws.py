"""Fuzzing the web viewer's WebSocket: control messages and connections, against a real server.

Two viewers run on loopback, a replay of a small run and a live source that takes stack commands
(``--allow-commands``, with its token). Each case either opens a connection with a ``Host``, ``Origin``
and token drawn from good and hostile ones (the answer must be what :class:`AccessPolicy` says: 403, or an
upgrade), or sends one control message on an open connection: good, edge and absurd ops and values
(400-digit and non-finite numbers, deep nesting, wrong types, binary frames, text that is not JSON, lines
with control characters, messages over the size limit). The answer must be the one
:func:`parse_control` decides: an ``error`` message with its text, an ``ack``, or frames going on. A
failure is an ``internal error`` or HTTP status in the stream, a connection dropped for a message within
the size limit, or a wrong answer; a hang is no answer within ``reply_s``, and counts only when it happens
again on a fresh connection (a loaded machine is not a hang).

    python -m tests.fuzz --target viewer --lines 20000
"""

from __future__ import annotations

import asyncio
import json
import random
import resource
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import aiohttp

from aamsim.viewer.frames import RunReplay
from aamsim.viewer.server import (
    MAX_MESSAGE_BYTES,
    AccessPolicy,
    ControlError,
    LiveSource,
    ReplaySource,
    ViewerApp,
    parse_control,
    start_site,
)
from tests.fuzz.scenario import Failure

TRAJ = ("id,simt,lat,lon,alt_m,tas_mps,cas_mps,gs_mps,trk_deg,vs_mps\n"
        + "".join(f"A{k % 3},{k // 3}.00,40.{k:04d},-74.0,150.0,50.0,50.0,50.0,90.0,0.0\n" for k in range(60)))
OPS = ["play", "pause", "seek", "speed", "stack", "", "PLAY", "explode", None, 1, ["seek"]]
VALUES: list[Any] = [0, 1, 5.5, 19.9, -1, 60, 1e5, 1e6, 1e300, -1e300, 10**400, -(10**400), True, None, "10", [],
                     {}, "ECHO hi", "CRE X EC35 40 -74 0 500 0", "x" * 600, "ECHO \x1b[2J", "a\nb", " ", ""]


def control_text(rng: random.Random) -> str | bytes:
    """One control message, as the page (or an attacker) might send it."""
    r = rng.random()
    if r < 0.7:
        msg: dict[str, Any] = {"op": rng.choice(OPS)}
        for key in rng.sample(["t", "x", "line", "extra"], rng.randint(0, 3)):
            msg[key] = rng.choice(VALUES)
        if rng.random() < 0.05:
            msg["t"] = float(rng.choice(["nan", "inf", "-inf"]))
        return json.dumps(msg)
    if r < 0.8:
        depth = rng.randint(10, 2000)  # as text: json.dumps itself stops near 1,000 levels
        return "[" * depth + '{"op": "seek", "t": 1}' + "]" * depth
    if r < 0.88:
        return "".join(chr(rng.randint(0, 0x2FFF)) for _ in range(rng.randint(0, 40)))
    if r < 0.94:
        return bytes(rng.randint(0, 255) for _ in range(rng.randint(0, 40)))
    if r < 0.98:
        return '{"op": "seek", "t": ' + "9" * rng.randint(300, MAX_MESSAGE_BYTES - 40) + "}"
    return '{"op": "pause", "pad": "' + "x" * rng.randint(MAX_MESSAGE_BYTES, 3 * MAX_MESSAGE_BYTES) + '"}'  # too big


HOSTS = ["{own}", "localhost:{port}", "127.0.0.1:{port}", "attacker.example:{port}", "", "[::1]:{port}",
         "localhost.:{port}", "evil.localhost:{port}", "127.0.0.1", "a b", "x" * 300]
ORIGINS = [None, "http://{own}", "http://attacker.example", "null", "file://", "http://{own}.evil", "https://{own}",
           "http://localhost:1", "", "javascript:alert(1)"]


@dataclass
class ViewerFuzzResult:
    target: str = "viewer"
    cases: int = 0
    messages: int = 0
    connections: int = 0
    refused_connections: int = 0
    error_replies: int = 0
    failures: list[Failure] = field(default_factory=list)
    unconfirmed_hangs: int = 0


class _Fuzzer:
    def __init__(self, rng: random.Random, result: ViewerFuzzResult, reply_s: float):
        self.rng, self.result, self.reply_s = rng, result, reply_s

    async def answer(self, ws: aiohttp.ClientWebSocketResponse, expect: str | None, live: bool) -> str | None:
        """Read until the expected answer; returns what was wrong, None when it came."""
        deadline = time.monotonic() + self.reply_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return "hang"
            try:
                msg = await ws.receive(timeout=left)
            except TimeoutError:
                return "hang"
            if msg.type != aiohttp.WSMsgType.TEXT:
                return f"connection ended ({msg.type.name}) after a message within the size limit"
            try:
                body = json.loads(msg.data, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
            except ValueError:
                return f"not strict JSON in the stream: {msg.data[:200]!r}"
            kind = body.get("type")
            if kind == "error":
                self.result.error_replies += 1
                if "internal error" in body.get("error", ""):
                    return f"crash: {body['error']}"
                if expect is None or expect not in body["error"]:
                    return f"unexpected error {body['error']!r} (expected {expect!r})"
                return None
            if kind == "ack":
                return None if expect is None else f"acknowledged, but expected the error {expect!r}"
            if kind == "frame" and expect is None and not live:
                return None  # obeyed silently; frames go on

    async def message_case(self, url: str, mode: str, allow: bool, token: str | None) -> None:
        text = control_text(self.rng)
        if isinstance(text, bytes):
            expect: str | None = "send control messages as JSON text"
        elif len(text.encode()) > MAX_MESSAGE_BYTES:
            expect = "<closed>"
        else:
            try:
                parsed = parse_control(text, mode, allow, token_ok=token is not None)
                expect = None
                if mode == "live" and parsed["op"] in ("play", "pause"):
                    expect = "<silent>"
            except ControlError as exc:
                expect = str(exc)
            except Exception as exc:  # noqa: BLE001 - the server's own check raises: the server fails on it too
                self.result.failures.append(Failure("crash", repr(text)[:500],
                                                    f"{mode}: parse_control raised {type(exc).__name__}: {exc}", 0.0))
                self.result.messages += 1
                return
        problem = await self._send(url, token, text, expect, mode == "live")
        if problem == "hang":
            again = await self._send(url, token, text, expect, mode == "live")
            if again != "hang":
                self.result.unconfirmed_hangs += 1
                problem = None
        if problem:
            self.result.failures.append(Failure("hang" if problem == "hang" else "wrong", repr(text)[:500],
                                                f"{mode}: {problem}", 0.0))
        self.result.messages += 1

    async def _send(self, url: str, token: str | None, text: str | bytes, expect: str | None, live: bool) -> str | None:
        query = f"?token={token}" if token else ""
        async with aiohttp.ClientSession() as http, http.ws_connect(url + "ws" + query,
                                                                    max_msg_size=0) as ws:
            if not live and (problem := await self.answer(ws, None, live)) is not None:  # the first frame
                return f"no first frame: {problem}"
            await (ws.send_bytes(text) if isinstance(text, bytes) else ws.send_str(text))
            if expect == "<closed>":
                msg = await ws.receive(timeout=self.reply_s)
                while msg.type == aiohttp.WSMsgType.TEXT:
                    msg = await ws.receive(timeout=self.reply_s)
                return None if msg.type in (aiohttp.WSMsgType.CLOSE, aiohttp.WSMsgType.CLOSED,
                                            aiohttp.WSMsgType.CLOSING) else f"oversize answered {msg.type.name}"
            if expect == "<silent>":
                await ws.send_str('{"op": "stack"}')  # a message that is always answered comes after it
                return await self.answer(ws, 'needs one command line' if token else "command token", live)
            return await self.answer(ws, expect, live)

    async def connection_case(self, url: str, app: ViewerApp, port: int) -> None:
        own = f"127.0.0.1:{port}"
        host = self.rng.choice(HOSTS).format(own=own, port=port)
        origin = self.rng.choice(ORIGINS)
        origin = origin.format(own=own) if origin is not None else None
        headers = {"Host": host} | ({"Origin": origin} if origin is not None else {})
        why = app.access.host_refusal(host) or app.access.origin_refusal(origin, host)
        self.result.connections += 1
        try:
            async with aiohttp.ClientSession() as http, http.ws_connect(url + "ws", headers=headers) as ws:
                upgraded = True
                await ws.close()
        except aiohttp.WSServerHandshakeError as exc:
            upgraded = False
            if exc.status != 403:
                self.result.failures.append(Failure("wrong", json.dumps(headers), f"handshake answered {exc.status}",
                                                    0.0))
        except (aiohttp.ClientError, ValueError) as exc:  # a Host the client library itself refuses to send
            self.result.refused_connections += 1
            del exc
            return
        if upgraded == (why is not None):
            self.result.failures.append(Failure("wrong", json.dumps(headers),
                                                f"upgraded={upgraded} but the policy says {why!r}", 0.0))
        if not upgraded:
            self.result.refused_connections += 1


async def _run(cases: int, seed: int, reply_s: float) -> ViewerFuzzResult:
    rng = random.Random(seed)
    result = ViewerFuzzResult()
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "trajectories.csv").write_text(TRAJ)
        replay = ViewerApp(ReplaySource(RunReplay(folder)))
        live = ViewerApp(LiveSource("fuzz"), allow_commands=True,
                         access=AccessPolicy.for_server(allow_commands=True))
        runners = []
        try:
            sites = []
            for app in (replay, live):
                runner, url = await start_site(app, "127.0.0.1", 0)
                runners.append(runner)
                sites.append((app, url, int(url.rsplit(":", 1)[1].strip("/"))))
            fuzzer = _Fuzzer(rng, result, reply_s)
            for _ in range(cases):
                app, url, port = rng.choice(sites)
                if rng.random() < 0.2:
                    await fuzzer.connection_case(url, app, port)
                else:
                    mode = app.source.mode
                    token = app.access.command_token if app.allow_commands and rng.random() < 0.7 else None
                    await fuzzer.message_case(url, mode, app.allow_commands, token)
                result.cases += 1
        finally:
            for runner in runners:
                await runner.cleanup()
    return result


def fuzz_viewer(cases: int, seed: int = 0, reply_s: float = 30.0) -> ViewerFuzzResult:
    """Run ``cases`` connection and message cases against two real viewers (replay and live)."""
    return asyncio.run(_run(cases, seed, reply_s))


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
