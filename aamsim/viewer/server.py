"""The web viewer's server: the page, its scripts, and a WebSocket stream of frames (aiohttp).

Two sources feed it. A :class:`ReplaySource` plays a run directory: each
browser tab has its own clock (play, pause, speed, seek) and gets the frame
of its clock ten times a second, computed on demand from the indexed run, so
a day of traffic never travels to the browser at once. A :class:`LiveSource`
holds the latest frame a running simulation published (:mod:`aamsim.viewer.live`);
every tab gets it at most ten times a second, however fast the simulation runs.

Everything served is read-only. The only message that changes anything is
``{"op": "stack", "line": ...}`` on a live source, and only when the server
was started with ``allow_commands`` *and* the WebSocket was opened with the
run's command token (a random secret made at start-up and printed in the
page's URL, ``?token=...``); otherwise it is refused with a message.

Who may ask at all: any page in the user's browser can try to reach
``127.0.0.1:8750``. So every request must name an allowed ``Host`` (an IP
literal, ``localhost``, the name the server was bound to, or a name the user
declared with ``--allow-host``), which defeats DNS rebinding (an attacker's
name resolving to 127.0.0.1 arrives with the attacker's name as ``Host``), and
a WebSocket upgrade that carries an ``Origin`` (every browser sends one) must
come from the viewer's own origin. A refused request gets a 403 naming why.
A bad request gets a 4xx (HTTP) or an ``error`` message (WebSocket) and the
server keeps serving; a tab that vanishes mid-stream ends only its own task.
"""

from __future__ import annotations

import asyncio
import hmac
import ipaddress
import json
import math
import secrets
import signal
import threading
import time
from collections import deque
from dataclasses import dataclass
from importlib import resources
from typing import Any
from urllib.parse import urlsplit

from aiohttp import WSMsgType, web

from aamsim.stop_signals import StopSignals
from aamsim.viewer.frames import STATUS_COLOURS, STATUS_NAMES, MapLayout, RunReplay, TrafficFrame

FRAME_PERIOD_S = 0.1  # ten frames per second of wall time: what a browser draws smoothly
MAX_MESSAGE_BYTES = 4096  # control messages are tiny; anything bigger is refused by aiohttp
STATIC_FILES = {"index.html": "text/html", "viewer.js": "text/javascript", "viewer.css": "text/css"}
PLAYBACK_SPEEDS = (1.0, 1e5)  # allowed range of replay speed-ups


class ControlError(ValueError):
    """A control message from the browser that cannot be obeyed (answered with its text)."""


# ---------------------------------------------------------------- sources
class ReplaySource:
    """A run directory; each client plays it on its own clock."""

    mode = "replay"

    def __init__(self, replay: RunReplay) -> None:
        self.replay = replay

    def meta(self) -> dict[str, Any]:
        r = self.replay
        summary = r.summary
        return {
            "mode": self.mode,
            "title": str(summary.get("scenario") or r.run_dir.name),
            "t_start": r.t_start,
            "t_end": r.t_end,
            "busiest": _busiest(r),
            "layout": r.layout().to_json(),
            "routes_by_id": r.routes_by_id,
            "totals": {"safety": summary.get("safety", {}), "operational": summary.get("operational", {})},
        }


def _busiest(r: RunReplay) -> dict[str, float]:
    """The sample with the most aircraft (the page offers it; benchmarks start there)."""
    counts = r.airborne_counts()
    if not len(counts):
        return {"t": r.t_start, "aircraft": 0}
    k = int(counts.argmax())
    return {"t": float(r.times[k]), "aircraft": int(counts[k])}


class LiveSource:
    """The latest frame of a running simulation, and the commands waiting for it."""

    mode = "live"

    def __init__(self, title: str, layout: MapLayout | None = None) -> None:
        self.title = title
        self.layout = layout
        self.frame: TrafficFrame | None = None
        self.seq = 0  # bumped by every publish
        self.layout_seq = 0  # bumped when the map changes (a bridge session on another scenario)
        self.events: deque[tuple[int, dict[str, Any]]] = deque(maxlen=500)
        self.commands: deque[str] = deque(maxlen=100)
        self.finished = False
        self._lock = threading.Lock()

    def publish(self, frame: TrafficFrame, layout: MapLayout | None = None) -> None:
        """Called from the simulation's thread; never blocks on a client."""
        with self._lock:
            self.seq += 1
            if layout is not None:
                self.layout = layout
                self.layout_seq += 1
            self.frame = frame
            for e in frame.to_json()["events"] if frame.events else ():
                self.events.append((self.seq, e))

    def latest(self, after_seq: int) -> tuple[int, TrafficFrame | None, list[dict[str, Any]]]:
        with self._lock:
            return self.seq, self.frame, [e for s, e in self.events if s > after_seq]

    def meta(self) -> dict[str, Any]:
        layout = self.layout
        return {
            "mode": self.mode,
            "title": self.title,
            "t_start": 0.0,
            "t_end": None,
            "layout": layout.to_json() if layout is not None else None,
            "routes_by_id": {},
            "totals": {},
            "layout_seq": self.layout_seq,
        }


Source = ReplaySource | LiveSource


@dataclass
class _Playback:
    t: float
    speed: float = 60.0
    playing: bool = True
    seeked: bool = False  # the next frame starts afresh (trails cleared, no events replayed)


# ---------------------------------------------------------------- who may ask
LOOPBACK_NAMES = frozenset({"localhost", "localhost.localdomain", "ip6-localhost", "ip6-loopback"})


def split_host(value: str) -> tuple[str, int | None] | None:
    """``Host`` header (or an origin's net location) -> (lower-case name, port); ``None`` if malformed."""
    try:
        parts = urlsplit("//" + value.strip())
        port = parts.port
    except ValueError:
        return None
    name = (parts.hostname or "").rstrip(".")
    return (name, port) if name else None


def _is_ip_literal(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


@dataclass(frozen=True)
class AccessPolicy:
    """The names a request may arrive under, and the secret that unlocks stack commands.

    An IP literal is always accepted as ``Host``: DNS rebinding needs a *name* the attacker controls,
    and a browser sends the name of the page's URL, so a numeric ``Host`` never comes from a
    rebinding page. Names must be loopback names, the name the server was bound to, or declared.
    """

    allowed_names: frozenset[str] = LOOPBACK_NAMES
    command_token: str | None = None

    @classmethod
    def for_server(cls, bind_host: str = "127.0.0.1", extra_names: tuple[str, ...] = (),
                   allow_commands: bool = False) -> AccessPolicy:
        names = set(LOOPBACK_NAMES)
        names.update(n.lower().rstrip(".") for n in (bind_host, *extra_names) if n and not _is_ip_literal(n))
        return cls(frozenset(names), secrets.token_urlsafe(18) if allow_commands else None)

    def host_refusal(self, host_header: str | None) -> str | None:
        """Why a request with this ``Host`` is refused, or ``None`` if it is accepted."""
        parsed = split_host(host_header or "")
        if parsed is None:
            return "a request must carry a valid Host header"
        name, _ = parsed
        if _is_ip_literal(name) or name in self.allowed_names:
            return None
        return (f"Host {name!r} is not served here (DNS rebinding protection); open the viewer by the address "
                "it printed, or start it with --allow-host NAME")

    def origin_refusal(self, origin: str | None, host_header: str | None) -> str | None:
        """Why a WebSocket upgrade from ``origin`` is refused (same-origin only), or ``None``."""
        if origin is None:
            return None  # not a browser (browsers always send Origin on a WebSocket upgrade)
        parts = urlsplit(origin.strip())
        own = split_host(host_header or "")
        theirs = split_host(parts.netloc) if parts.scheme in ("http", "https") else None
        if own is None or theirs is None:
            return f"cross-origin WebSocket from {origin!r} refused"
        default_port = 443 if parts.scheme == "https" else 80
        if theirs[0] == own[0] and (theirs[1] or default_port) == (own[1] or default_port):
            return None
        return f"cross-origin WebSocket from {origin!r} refused: only the viewer's own page may connect"

    def token_matches(self, token: str | None) -> bool:
        if self.command_token is None or not token:
            return False
        return hmac.compare_digest(token.encode(), self.command_token.encode())


# ---------------------------------------------------------------- control messages
MAX_CONTROL_NESTING = 32  # arrays and objects inside one another in a control message


def _nesting_depth(text: str | bytes) -> int:
    """The deepest nesting of JSON arrays and objects in ``text``, brackets inside strings not counted."""
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="replace")
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


def parse_control(text: str | bytes, mode: str, allow_commands: bool, token_ok: bool = True) -> dict[str, Any]:
    """Check one control message; raises :class:`ControlError` naming what is wrong.

    ``allow_commands``: the server takes stack commands at all; ``token_ok``: this connection
    presented the run's command token.
    """
    if _nesting_depth(text) > MAX_CONTROL_NESTING:
        # Decided before parsing: how deep json.loads gets depends on the stack it runs on, and the
        # answer to a message must not.
        raise ControlError(f"nested deeper than {MAX_CONTROL_NESTING} levels: a control message is a JSON object "
                           "with an \"op\" field")
    try:
        msg = json.loads(text)
    except (ValueError, RecursionError):  # JSONDecodeError, bad UTF-8, an integer past Python's digit limit
        raise ControlError("not JSON: send an object such as {\"op\": \"pause\"}") from None
    if not isinstance(msg, dict):
        raise ControlError("a control message is a JSON object with an \"op\" field")
    op = msg.get("op")
    if op in ("play", "pause"):
        return {"op": op}
    if op in ("seek", "speed"):
        key = "t" if op == "seek" else "x"
        value = msg.get(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not _is_finite(value):
            raise ControlError(f"\"{op}\" needs a finite number in \"{key}\"")
        if mode != "replay":
            raise ControlError(f"\"{op}\" works on a replay; a live simulation runs at its own pace")
        if op == "speed" and not PLAYBACK_SPEEDS[0] <= value <= PLAYBACK_SPEEDS[1]:
            raise ControlError(f"speed must be between {PLAYBACK_SPEEDS[0]:g} and {PLAYBACK_SPEEDS[1]:g}")
        return {"op": op, key: float(value)}
    if op == "stack":
        line = msg.get("line")
        if not allow_commands:
            raise ControlError("stack commands are disabled: the viewer serves read-only data unless started "
                               "with --allow-commands")
        if mode != "live":
            raise ControlError("stack commands need a live simulation, not a replay")
        if not token_ok:
            raise ControlError("stack commands need the command token: open the viewer by the URL it printed "
                               "(it ends in ?token=...)")
        if not isinstance(line, str) or not line.strip() or len(line) > 512 or "\n" in line:
            raise ControlError("\"stack\" needs one command line (text, at most 512 characters) in \"line\"")
        return {"op": "stack", "line": line.strip()}
    raise ControlError(f"unknown op {op!r}; known: play, pause, seek, speed, stack")


def _is_finite(value: float) -> bool:
    """``math.isfinite`` that says False for an integer too large for a float (``1`` and 400 zeros):
    ``math.isfinite`` raised OverflowError there, and the WebSocket stream got an HTTP 500."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


# ---------------------------------------------------------------- the application
class ViewerApp:
    """The aiohttp application around one source."""

    def __init__(self, source: Source, *, allow_commands: bool = False, access: AccessPolicy | None = None) -> None:
        self.source = source
        self.allow_commands = allow_commands
        self.access = access or AccessPolicy.for_server(allow_commands=allow_commands)
        if allow_commands and self.access.command_token is None:
            raise ValueError("a viewer that takes commands needs an AccessPolicy with a command token")
        self.clients = 0
        self.last_sent: dict[str, Any] = {}
        self.app = web.Application(client_max_size=MAX_MESSAGE_BYTES, middlewares=[self._guard, self._errors])
        self.app.router.add_get("/", self._index)
        self.app.router.add_get("/static/{name}", self._static)
        self.app.router.add_get("/api/meta", self._meta)
        self.app.router.add_get("/api/status", self._status)
        self.app.router.add_get("/api/frame", self._frame)
        self.app.router.add_get("/ws", self._ws)
        self.sockets: set[web.WebSocketResponse] = set()
        self.app.on_shutdown.append(self._close_sockets)

    async def _close_sockets(self, app: web.Application) -> None:
        """Ctrl-C: tell open tabs the server is going (1001) instead of waiting for them to leave."""
        for ws in list(self.sockets):
            await ws.close(code=1001, message=b"viewer stopped")

    def page_url(self, base_url: str) -> str:
        """The URL to open: ``base_url`` plus the command token when commands are allowed."""
        token = self.access.command_token if self.allow_commands else None
        return f"{base_url}?token={token}" if token else base_url

    @web.middleware
    async def _guard(self, request: web.Request, handler: Any) -> web.StreamResponse:
        """Host check on every request (DNS rebinding), same-origin check on WebSocket upgrades."""
        why = self.access.host_refusal(request.headers.get("Host"))
        if why is None and request.path == "/ws":
            why = self.access.origin_refusal(request.headers.get("Origin"), request.headers.get("Host"))
        if why is not None:
            return web.Response(status=403, text=f"403 Forbidden: {why}")
        return await handler(request)

    @web.middleware
    async def _errors(self, request: web.Request, handler: Any) -> web.StreamResponse:
        try:
            return await handler(request)
        except web.HTTPException as exc:
            if exc.status in (404, 405) and exc.text in (None, "", f"{exc.status}: {exc.reason}"):
                exc.text = (f"{exc.status} {exc.reason}: {request.method} {request.path}; the viewer answers GET on "
                            "/, /static/<file>, /api/meta, /api/status, /api/frame?t=<s> and /ws")
            raise
        except Exception as exc:  # noqa: BLE001  (a handler bug answers 500 and the server keeps serving)
            return web.json_response({"error": f"internal error: {type(exc).__name__}: {exc}"}, status=500)

    # ------------------------------------------------------------ HTTP
    async def _index(self, request: web.Request) -> web.Response:
        return self._file("index.html")

    async def _static(self, request: web.Request) -> web.Response:
        name = request.match_info["name"]
        if name not in STATIC_FILES:
            raise web.HTTPNotFound(text=f"no static file {name!r}; the viewer ships {', '.join(STATIC_FILES)}")
        return self._file(name)

    def _file(self, name: str) -> web.Response:
        body = resources.files("aamsim.viewer").joinpath("static", name).read_bytes()
        return web.Response(body=body, content_type=STATIC_FILES[name], charset="utf-8",
                            headers={"Cache-Control": "no-cache"})

    async def _meta(self, request: web.Request) -> web.Response:
        meta = self.source.meta()
        meta.update(status_names=list(STATUS_NAMES), status_colours=list(STATUS_COLOURS),
                    frame_period_s=FRAME_PERIOD_S, allow_commands=self.allow_commands)
        return web.json_response(meta)

    async def _status(self, request: web.Request) -> web.Response:
        src = self.source
        body = {"mode": src.mode, "clients": self.clients, **self.last_sent}
        if isinstance(src, LiveSource):
            body["finished"] = src.finished
            body["published"] = src.seq
        return web.json_response(body)

    async def _frame(self, request: web.Request) -> web.Response:
        src = self.source
        if isinstance(src, ReplaySource):
            raw = request.query.get("t")
            if raw is None:
                raise web.HTTPBadRequest(text="/api/frame needs ?t=<sim time in seconds> on a replay")
            try:
                t = float(raw)
            except ValueError:
                raise web.HTTPBadRequest(text=f"t={raw!r} is not a number of seconds") from None
            if not math.isfinite(t):
                raise web.HTTPBadRequest(text=f"t={raw!r} is not a finite number of seconds")
            return web.json_response(src.replay.frame_at(t).to_json())
        _, frame, _ = src.latest(0)
        if frame is None:
            raise web.HTTPServiceUnavailable(text="no frame published yet: the simulation has not stepped")
        return web.json_response(frame.to_json())

    # ------------------------------------------------------------ WebSocket
    async def _ws(self, request: web.Request) -> web.WebSocketResponse:
        ws = web.WebSocketResponse(heartbeat=20.0, max_msg_size=MAX_MESSAGE_BYTES)
        await ws.prepare(request)
        self.clients += 1
        self.sockets.add(ws)
        src = self.source
        play = _Playback(t=src.replay.t_start if isinstance(src, ReplaySource) else 0.0)
        token_ok = self.access.token_matches(request.query.get("token"))
        sender = asyncio.create_task(self._send_loop(ws, play))
        try:
            async for msg in ws:
                if msg.type == WSMsgType.TEXT:
                    try:
                        await self._control(ws, play, msg.data, token_ok)
                    except Exception as exc:  # noqa: BLE001  (a bug answers this message; the stream goes on)
                        await _send(ws, {"type": "error", "error": f"internal error: {type(exc).__name__}"})
                elif msg.type == WSMsgType.BINARY:
                    await _send(ws, {"type": "error", "error": "send control messages as JSON text"})
                elif msg.type == WSMsgType.ERROR:
                    break
        finally:
            sender.cancel()
            self.clients -= 1
            self.sockets.discard(ws)
        return ws

    async def _control(self, ws: web.WebSocketResponse, play: _Playback, text: str, token_ok: bool) -> None:
        try:
            msg = parse_control(text, self.source.mode, self.allow_commands, token_ok)
        except ControlError as exc:
            await _send(ws, {"type": "error", "error": str(exc)})
            return
        op = msg["op"]
        if op == "play":
            play.playing = True
        elif op == "pause":
            play.playing = False
        elif op == "seek":
            assert isinstance(self.source, ReplaySource)
            play.t = min(max(msg["t"], self.source.replay.t_start), self.source.replay.t_end)
            play.seeked = True
        elif op == "speed":
            play.speed = msg["x"]
        elif op == "stack":
            assert isinstance(self.source, LiveSource)
            self.source.commands.append(msg["line"])
            await _send(ws, {"type": "ack", "op": "stack", "line": msg["line"]})

    async def _send_loop(self, ws: web.WebSocketResponse, play: _Playback) -> None:
        src = self.source
        last_wall = time.perf_counter()
        last_t: float | None = None
        seen_seq = 0
        try:
            while not ws.closed:
                now = time.perf_counter()
                if isinstance(src, ReplaySource):
                    r = src.replay
                    if play.playing and last_t is not None:  # the clock starts at the first frame, not before
                        play.t = min(play.t + play.speed * (now - last_wall), r.t_end)
                        if play.t >= r.t_end:
                            play.playing = False
                    jumped = play.seeked or last_t is None or play.t < last_t
                    play.seeked = False
                    frame = r.frame_at(play.t, events_since=None if jumped else last_t)
                    body = frame.to_json()
                    body.update(type="frame", reset=jumped, playing=play.playing, speed=play.speed)
                    last_t = play.t
                else:
                    seq, live, events = src.latest(seen_seq)
                    if live is None or seq == seen_seq:
                        last_wall = now
                        await asyncio.sleep(FRAME_PERIOD_S)
                        continue
                    body = live.to_json()
                    body.update(type="frame", reset=seen_seq == 0, playing=not src.finished, events=events,
                                finished=src.finished, layout_seq=src.layout_seq, title=src.title)
                    seen_seq = seq
                last_wall = now
                self.last_sent = {"simt": body["simt"], "aircraft": len(body["ids"])}
                await _send(ws, body)
                await asyncio.sleep(max(0.0, FRAME_PERIOD_S - (time.perf_counter() - now)))
        except (ConnectionError, asyncio.CancelledError, RuntimeError):
            return  # the tab went away: only this stream ends


async def _send(ws: web.WebSocketResponse, body: dict[str, Any]) -> None:
    if not ws.closed:
        await ws.send_str(json.dumps(body, separators=(",", ":"), allow_nan=False))


def is_loopback(host: str) -> bool:
    return host in ("127.0.0.1", "localhost", "::1") or host.startswith("127.")


async def start_site(viewer: ViewerApp, host: str, port: int) -> tuple[web.AppRunner, str]:
    """Start serving; returns the runner (to clean up) and the URL (with the port actually bound)."""
    runner = web.AppRunner(viewer.app, access_log=None, handle_signals=False, shutdown_timeout=2.0)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    await site.start()
    server = site._server  # the bound port when port was 0
    sockets = getattr(server, "sockets", None) or ()
    bound = sockets[0].getsockname()[1] if sockets else port
    shown = f"[{host}]" if ":" in host else host
    return runner, f"http://{shown}:{bound}/"


def interrupted_by_signals() -> StopSignals:
    """Ctrl-C (SIGINT) and SIGTERM raise KeyboardInterrupt inside the ``with`` block, whatever the process
    inherited (a viewer started as a background job ignores SIGINT, and ``asyncio.run`` puts in its own
    Ctrl-C handler only over Python's default one)."""
    return StopSignals(signal.default_int_handler)


def serve_replay(run_dir: str, host: str, port: int, on_ready: Any, allow_hosts: tuple[str, ...] = (),
                 on_warning: Any = None) -> None:
    """``aamsim view RUN_DIR``: serve a replay until interrupted (Ctrl-C); ``on_warning(text)`` hears
    what was left out of the run directory (a last row cut short)."""
    replay = RunReplay(run_dir)
    for warning in replay.warnings if on_warning is not None else ():
        on_warning(warning)
    viewer = ViewerApp(ReplaySource(replay), access=AccessPolicy.for_server(host, allow_hosts))

    async def main() -> None:
        runner, url = await start_site(viewer, host, port)
        on_ready(url)
        try:
            while True:
                await asyncio.sleep(3600)
        finally:
            await runner.cleanup()

    try:
        with interrupted_by_signals():
            asyncio.run(main())
    except KeyboardInterrupt:
        pass
