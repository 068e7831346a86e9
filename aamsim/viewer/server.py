"""The web viewer's server: the page, its scripts, and a WebSocket stream of frames (aiohttp).

Two sources feed it. A :class:`ReplaySource` plays a run directory: each
browser tab has its own clock (play, pause, speed, seek) and gets the frame
of its clock ten times a second, computed on demand from the indexed run, so
a day of traffic never travels to the browser at once. A :class:`LiveSource`
holds the latest frame a running simulation published (:mod:`aamsim.viewer.live`);
every tab gets it at most ten times a second, however fast the simulation runs.

Everything served is read-only. The only message that changes anything is
``{"op": "stack", "line": ...}`` on a live source, and only when the server
was started with ``allow_commands``; otherwise it is refused with a message.
A bad request gets a 4xx (HTTP) or an ``error`` message (WebSocket) and the
server keeps serving; a tab that vanishes mid-stream ends only its own task.
"""

from __future__ import annotations

import asyncio
import json
import math
import threading
import time
from collections import deque
from dataclasses import dataclass
from importlib import resources
from typing import Any

from aiohttp import WSMsgType, web

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


# ---------------------------------------------------------------- control messages
def parse_control(text: str | bytes, mode: str, allow_commands: bool) -> dict[str, Any]:
    """Check one control message; raises :class:`ControlError` naming what is wrong."""
    try:
        msg = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError):
        raise ControlError("not JSON: send an object such as {\"op\": \"pause\"}") from None
    if not isinstance(msg, dict):
        raise ControlError("a control message is a JSON object with an \"op\" field")
    op = msg.get("op")
    if op in ("play", "pause"):
        return {"op": op}
    if op in ("seek", "speed"):
        key = "t" if op == "seek" else "x"
        value = msg.get(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
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
        if not isinstance(line, str) or not line.strip() or len(line) > 512 or "\n" in line:
            raise ControlError("\"stack\" needs one command line (text, at most 512 characters) in \"line\"")
        return {"op": "stack", "line": line.strip()}
    raise ControlError(f"unknown op {op!r}; known: play, pause, seek, speed, stack")


# ---------------------------------------------------------------- the application
class ViewerApp:
    """The aiohttp application around one source."""

    def __init__(self, source: Source, *, allow_commands: bool = False) -> None:
        self.source = source
        self.allow_commands = allow_commands
        self.clients = 0
        self.last_sent: dict[str, Any] = {}
        self.app = web.Application(client_max_size=MAX_MESSAGE_BYTES, middlewares=[self._errors])
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
        sender = asyncio.create_task(self._send_loop(ws, play))
        try:
            async for msg in ws:
                if msg.type == WSMsgType.TEXT:
                    await self._control(ws, play, msg.data)
                elif msg.type == WSMsgType.BINARY:
                    await _send(ws, {"type": "error", "error": "send control messages as JSON text"})
                elif msg.type == WSMsgType.ERROR:
                    break
        finally:
            sender.cancel()
            self.clients -= 1
            self.sockets.discard(ws)
        return ws

    async def _control(self, ws: web.WebSocketResponse, play: _Playback, text: str) -> None:
        try:
            msg = parse_control(text, self.source.mode, self.allow_commands)
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
                    if play.playing:
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


def serve_replay(run_dir: str, host: str, port: int, on_ready: Any) -> None:
    """``aamsim view RUN_DIR``: serve a replay until interrupted (Ctrl-C)."""
    viewer = ViewerApp(ReplaySource(RunReplay(run_dir)))

    async def main() -> None:
        runner, url = await start_site(viewer, host, port)
        on_ready(url)
        try:
            while True:
                await asyncio.sleep(3600)
        finally:
            await runner.cleanup()

    try:
        asyncio.run(main())
    except KeyboardInterrupt:
        pass
