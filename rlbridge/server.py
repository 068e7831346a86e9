"""The headless simulation server: one ZeroMQ ROUTER socket, one simulation per client.

Clients (``rlbridge.client.RemoteEpisode``, or any ZeroMQ DEALER/REQ socket
speaking ``docs/protocol.md``) are told apart by their routing identity;
each owns a :class:`Session` holding an :class:`~rlbridge.core.EpisodeCore`.
The loop polls with a short timeout so that :meth:`SimulationServer.stop`
(called by the SIGINT/SIGTERM handlers of :func:`rlbridge.plugin.serve`)
ends it promptly, and frees sessions whose client has been silent longer
than the session timeout. Every request gets exactly one reply, an error
reply when the request is bad; nothing a client sends stops the server
(except ``shutdown``, when enabled).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import zmq

from aamsim.clock import DT_MAX_S, DT_MIN_S
from aamsim.errors import CommandError
from aamsim.limits import DEFAULT_MAX_AIRCRAFT, SimulationLimits
from rlbridge.core import EpisodeCore, ScenarioError
from rlbridge.heap import release_memory
from rlbridge.protocol import (
    DEFAULT_MAX_MESSAGE_BYTES,
    PROTOCOL_VERSION,
    ProtocolError,
    check_fields,
    decode,
    error_reply,
    peek_id,
    reply,
)
from rlbridge.scenario_access import ScenarioAccessError, ScenarioRoots
from rlbridge.wire import (
    actions_from_payload,
    snapshot_fields_from_request,
    snapshot_to_payload,
    step_result_to_payload,
)

log = logging.getLogger(__name__)

DEFAULT_BIND = "tcp://127.0.0.1:5555"


@dataclass(frozen=True)
class ServerOptions:
    """Server settings (``aamsim serve`` options)."""

    bind: str = DEFAULT_BIND
    plugins: tuple[str, ...] = ()  # loaded into every session's simulation
    max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES  # larger requests get a too_large error reply
    session_timeout_s: float = 300.0  # a silent client's simulation is freed after this
    max_sessions: int = 64
    scenario_roots: tuple[Path, ...] = ()  # empty: the working directory
    allow_shutdown: bool = False  # honour the shutdown request
    allow_live_overlays: bool = False  # clients may start live OpenSky overlays (the server polls the network)
    max_aircraft: int = DEFAULT_MAX_AIRCRAFT  # aircraft flying at once in one session
    poll_interval_s: float = 0.1  # how often the loop checks the stop flag and idle sessions
    # Called with (session number, episode) after every reset and step that moved a simulation
    # (``aamsim serve --view`` shows the traffic of the session that moved last).
    on_traffic: Callable[[int, EpisodeCore], None] | None = None

    def session_limits(self) -> SimulationLimits:
        """What every client's simulation may do (see :class:`aamsim.limits.SimulationLimits`)."""
        return SimulationLimits(live_data=self.allow_live_overlays, max_aircraft=self.max_aircraft,
                                why="a limit of this server (aamsim serve --allow-live-overlays, --max-aircraft)")

    def transport_limit_bytes(self) -> int:
        """zmq MAXMSGSIZE: a frame above it makes zmq drop the connection (no reply possible)."""
        return 2 * self.max_message_bytes + 65536


@dataclass
class Session:
    identity: bytes
    last_seen: float
    core: EpisodeCore | None = None
    requests: int = 0


def _refuse_policy_files(usecase: str, params: dict[str, Any]) -> None:
    """A client names frozen policies by baseline name only: the server loads no file a client names."""
    from rlbridge.usecases.registry import usecase_spec

    try:
        names = usecase_spec(usecase).policy_params
    except KeyError:
        return  # the use case's own error comes with the episode
    if not names:
        return
    from rlbridge.agents import BASELINE_KINDS

    for name in names:
        value = params.get(name)
        if isinstance(value, str) and value not in BASELINE_KINDS:
            raise RequestError("forbidden", f"{usecase}: {name}={value!r}: over the bridge a frozen policy is a "
                               f"baseline ({', '.join(BASELINE_KINDS)}); the server loads no policy file a client "
                               "names")


class RequestError(Exception):
    """A request the server understood but cannot carry out (error reply with ``code``)."""

    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code = code


RELEASE_AFTER_BYTES = 256 * 1024  # a request at least this large is followed by release_memory()


class ServerStopping(BaseException):
    """Raised by the stop-signal handler inside a long request so that SIGTERM/SIGINT end it promptly.

    A BaseException, so that the request's own error handling (``except
    Exception``) cannot swallow it.
    """


_NUM, _STR, _INT, _NIL = (float,), (str,), (int,), (type(None),)

# Bounds of every numeric request field, checked in one place (docs/protocol.md lists them).
# ``params.<name>`` bounds a use-case parameter when the client sends it.
MAX_TIME_LIMIT_S = 1e6  # 11.6 days of simulated time per episode
MAX_DECISION_INTERVAL_S = 3600.0
MAX_ECHOED_ERRORS = 20  # parse errors sent back with open/reset; the rest are counted
MAX_ECHOED_CHARS = 200  # of each
FIELD_BOUNDS: dict[str, tuple[float, float, bool, str]] = {  # name: (low, high, low included, meaning)
    "dt": (DT_MIN_S, DT_MAX_S, True, "time step [s]"),
    "time_limit_s": (0.0, MAX_TIME_LIMIT_S, False, "episode time limit [s]"),
    "seed": (0, 2**63 - 1, True, "random seed"),
    "params.decision_interval_s": (0.0, MAX_DECISION_INTERVAL_S, False, "decision interval [s]"),
}


def check_bounds(message: dict[str, Any]) -> None:
    """Refuse a numeric field outside :data:`FIELD_BOUNDS` (or not finite) with a ``bad_request`` error."""
    params = message.get("params")
    for name, (low, high, low_included, what) in FIELD_BOUNDS.items():
        group, _, key = name.rpartition(".")
        holder = params if group == "params" else message
        if not isinstance(holder, dict) or key not in holder:
            continue
        value = holder[key]
        if value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
            continue  # types are check_fields' (and the use case's) business
        above_low = value >= low if low_included else value > low
        if not (math.isfinite(value) and above_low and value <= high):
            interval = f"{'[' if low_included else '('}{low:g}, {high:g}]"
            raise RequestError("bad_request", f"{name} ({what}) must be in {interval}, not {value!r}")


def _capped(errors: list[str]) -> list[str]:
    """At most MAX_ECHOED_ERRORS messages of at most MAX_ECHOED_CHARS each, and a count of the rest."""
    out = [e if len(e) <= MAX_ECHOED_CHARS else e[:MAX_ECHOED_CHARS - 3] + "..." for e in errors[:MAX_ECHOED_ERRORS]]
    if len(errors) > MAX_ECHOED_ERRORS:
        out.append(f"... and {len(errors) - MAX_ECHOED_ERRORS} more error(s)")
    return out
_OPEN_FIELDS: dict[str, tuple[tuple[type, ...], bool]] = {
    "scenario": (_STR, True), "usecase": (_STR, False), "params": ((dict,), False),
    "time_limit_s": (_NUM + _NIL, False), "dt": (_NUM, False),
}
SCHEMAS: dict[str, dict[str, tuple[tuple[type, ...], bool]]] = {
    "hello": {"client": (_STR, False)},
    "open": _OPEN_FIELDS,
    "reset": {**{k: (kinds, False) for k, (kinds, _) in _OPEN_FIELDS.items()}, "seed": (_INT + _NIL, False),
              "targets": ((bool,), False)},
    "step": {"actions": ((dict, np.ndarray), False), "agents": ((list,), False)},
    "stack": {"text": (_STR, True)},
    "state": {"fields": ((list,), False)},
    "metrics": {"groups": ((list,), False)},
    "close": {},
    "shutdown": {},
}


class SimulationServer:
    """Serves simulations over one ROUTER socket until :meth:`stop` is called."""

    def __init__(self, options: ServerOptions = ServerOptions()):
        self.options = options
        self.roots = ScenarioRoots(options.scenario_roots)
        self.sessions: dict[bytes, Session] = {}
        self.started = time.monotonic()
        self._stop = False
        self.busy = False  # answering a request (a stop signal then abandons it)
        self._freed = False  # a session was freed while answering: release memory after the reply
        self._context = zmq.Context()
        self._socket = self._context.socket(zmq.ROUTER)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.setsockopt(zmq.MAXMSGSIZE, options.transport_limit_bytes())
        self._socket.setsockopt(zmq.ROUTER_HANDOVER, 1)  # a client that reconnects keeps its session
        try:
            self._socket.bind(options.bind)
        except zmq.ZMQError:
            self._socket.close(0)
            self._context.term()
            raise
        self.endpoint: str = self._socket.getsockopt_string(zmq.LAST_ENDPOINT)
        self._handlers: dict[str, Callable[[Session | None, bytes, dict[str, Any]], dict[str, Any]]] = {
            "hello": self._hello, "open": self._open, "reset": self._reset, "step": self._step,
            "stack": self._stack, "state": self._state, "metrics": self._metrics, "close": self._close,
            "shutdown": self._shutdown,
        }

    # ------------------------------------------------------------------ loop
    def stop(self) -> None:
        """Ask the loop to end (safe from a signal handler or another thread)."""
        self._stop = True

    def stop_from_signal(self) -> None:
        """Stop, and abandon the request under way (a long step) with a ``stopping`` error reply.

        Call only from a signal handler in the thread that serves: it raises
        :class:`ServerStopping` there when a request is being answered.
        """
        self._stop = True
        if self.busy:
            raise ServerStopping()

    def serve_forever(self) -> None:
        """Serve until :meth:`stop`; then free every session and close the socket."""
        log.info("serving on %s (protocol v%d)", self.endpoint, PROTOCOL_VERSION)
        poll_ms = max(1, int(self.options.poll_interval_s * 1000))
        try:
            while not self._stop:
                if self._socket.poll(poll_ms, zmq.POLLIN):
                    self._drain()
                self.reap_idle(time.monotonic())
        finally:
            self.close()

    def _drain(self) -> None:
        for _ in range(100):  # bounded, so that stop and idle checks still run under load
            if self._stop:
                return
            try:
                frames = self._socket.recv_multipart(zmq.NOBLOCK, copy=False)
            except zmq.Again:
                return
            release = self.handle(frames)
            del frames  # the last reference to the message's buffers: free them before release_memory()
            if release:
                release_memory()

    def close(self) -> None:
        for session in self.sessions.values():
            if session.core is not None:
                session.core.close()
        self.sessions.clear()
        if not self._socket.closed:
            self._socket.close(0)
            self._context.term()
            log.info("server on %s closed", self.endpoint)

    def reap_idle(self, now: float) -> None:
        """Free the sessions of clients silent for longer than the session timeout."""
        limit = self.options.session_timeout_s
        for identity in [k for k, s in self.sessions.items() if now - s.last_seen > limit]:
            session = self.sessions.pop(identity)
            if session.core is not None:
                session.core.close()
            del session
            release_memory()
            log.info("session %s idle for more than %.1f s: freed", identity.hex(), limit)

    # -------------------------------------------------------------- requests
    def handle(self, frames: list[Any]) -> bool:
        """Answer one message ``[identity, (empty delimiter,) header, buffers...]``.

        Returns whether the caller should call :func:`~rlbridge.heap.release_memory`
        once it has dropped ``frames`` (a large message, or a session freed): called
        here, it would run while the caller still holds the message, whose buffers
        (15 MB) were then freed after it and stayed resident.
        """
        identity = bytes(frames[0])
        body = frames[1:]
        envelope: list[Any] = [identity]
        if body and len(body[0]) == 0:  # a REQ client: keep its delimiter
            envelope.append(b"")
            body = body[1:]
        self.busy = True
        try:
            answer = self._answer(identity, body)
        except ServerStopping:
            answer = error_reply(peek_id(body), "stopping", "the server is stopping (signal received)")
        finally:
            self.busy = False
        self._socket.send_multipart(envelope + answer, copy=False)
        release = self._freed or sum(len(f) for f in body) >= RELEASE_AFTER_BYTES
        self._freed = False
        return release

    def _answer(self, identity: bytes, body: list[Any]) -> list[Any]:
        msg_id = None
        try:
            message = decode(body, self.options.max_message_bytes)
            msg_id = message.get("id")
            op = message.get("op")
            if not isinstance(op, str):
                raise ProtocolError(f"op must be a string naming the request, not {type(op).__name__}")
            handler = self._handlers.get(op)
            if handler is None:
                raise RequestError("unknown_op", f"unknown op {op!r}; known: {', '.join(self._handlers)}")
            check_fields(message, SCHEMAS[op])
            check_bounds(message)
            session = self.sessions.get(identity)
            if session is not None:
                session.last_seen = time.monotonic()
                session.requests += 1
            answer = reply(msg_id, **handler(session, identity, message))
            session = self.sessions.get(identity)
            if session is not None:  # silence counts from the answer: a reset that took long is not idleness
                session.last_seen = time.monotonic()
            if op in ("reset", "step") and self.options.on_traffic is not None:
                self._show(identity)
            return answer
        except ProtocolError as exc:
            msg_id = msg_id if msg_id is not None else peek_id(body)
            log.warning("bad request from %s: %s", identity.hex(), exc)
            return error_reply(msg_id, exc.code, str(exc))
        except RequestError as exc:
            return error_reply(msg_id, exc.code, str(exc))
        except ScenarioAccessError as exc:
            return error_reply(msg_id, exc.code, str(exc))
        except (CommandError, ScenarioError, KeyError, ValueError, TypeError, RuntimeError, OSError) as exc:
            log.info("request from %s failed: %s: %s", identity.hex(), type(exc).__name__, exc)
            return error_reply(msg_id, "bad_request", f"{type(exc).__name__}: {exc}")
        except Exception as exc:  # the boundary: a bug in one session must not stop the server
            log.exception("internal error answering %s", identity.hex())
            return error_reply(msg_id, "internal", f"internal error: {type(exc).__name__}: {exc}")

    def _show(self, identity: bytes) -> None:
        """Hand the session's traffic to the viewer; a viewer failure never fails the request."""
        session = self.sessions.get(identity)
        if session is None or session.core is None or session.core.sim is None or self.options.on_traffic is None:
            return
        try:
            self.options.on_traffic(list(self.sessions).index(identity) + 1, session.core)
        except Exception:
            log.exception("the viewer could not show session %s", identity.hex())

    def _need_core(self, session: Session | None) -> EpisodeCore:
        if session is None or session.core is None:
            raise RequestError("no_session", "no open session for this client: send open (or reset with a "
                                             "scenario) first")
        return session.core

    # ------------------------------------------------------------------- ops
    def _hello(self, session: Session | None, identity: bytes, message: dict[str, Any]) -> dict[str, Any]:
        from aamsim import __version__
        from rlbridge.usecases.registry import available

        return {"server": "aamsim", "version": __version__, "protocol": PROTOCOL_VERSION,
                "sessions": len(self.sessions), "max_sessions": self.options.max_sessions,
                "max_message_bytes": self.options.max_message_bytes,
                "session_timeout_s": self.options.session_timeout_s, "usecases": available(),
                "plugins": list(self.options.plugins)}

    def _open(self, session: Session | None, identity: bytes, message: dict[str, Any]) -> dict[str, Any]:
        if session is None and len(self.sessions) >= self.options.max_sessions:
            raise RequestError("busy", f"the server already serves {self.options.max_sessions} sessions")
        path = self.roots.resolve(message["scenario"])
        _refuse_policy_files(message.get("usecase", "corridor_sa"), message.get("params") or {})
        dt = float(message.get("dt", 0.05))  # within FIELD_BOUNDS (check_bounds)
        core = EpisodeCore(path, message.get("usecase", "corridor_sa"), message.get("params") or {},
                           time_limit_s=message.get("time_limit_s"), dt=dt, plugins=self.options.plugins,
                           file_guard=self.roots.guard, limits=self.options.session_limits())
        if session is None:
            session = self.sessions[identity] = Session(identity, time.monotonic())
            log.info("session %s opened: %s", identity.hex(), path.name)
        elif session.core is not None:
            session.core.close()
        session.core = core
        return {"possible_agents": list(core.possible_agents), "parse_errors": _capped(list(core.parse_errors)),
                "time_limit_s": core.time_limit_s, "scenario": str(path)}

    def _reset(self, session: Session | None, identity: bytes, message: dict[str, Any]) -> dict[str, Any]:
        opened: dict[str, Any] = {}
        if "scenario" in message:
            fields = {k: message[k] for k in _OPEN_FIELDS if k in message}
            opened = self._open(session, identity, {"op": "open", **fields})
            session = self.sessions[identity]
        elif set(message) & set(_OPEN_FIELDS):
            raise ProtocolError("reset: usecase, params, time_limit_s and dt need a scenario")
        core = self._need_core(session)
        core.publish_targets = bool(message.get("targets", False))  # asked for at each reset
        return {**step_result_to_payload(core.reset(message.get("seed"))), **opened}

    def _step(self, session: Session | None, identity: bytes, message: dict[str, Any]) -> dict[str, Any]:
        core = self._need_core(session)
        if core.sim is None:
            raise RequestError("bad_request", "step before reset")
        return step_result_to_payload(core.step(actions_from_payload(message)))

    def _stack(self, session: Session | None, identity: bytes, message: dict[str, Any]) -> dict[str, Any]:
        core = self._need_core(session)
        if core.sim is None:
            raise RequestError("bad_request", "stack before reset")
        return {"messages": core.stack(message["text"])}

    def _state(self, session: Session | None, identity: bytes, message: dict[str, Any]) -> dict[str, Any]:
        core = self._need_core(session)
        if core.sim is None:
            raise RequestError("bad_request", "state before reset")
        fields = snapshot_fields_from_request(message.get("fields"))
        if fields is None:
            return core.traffic_state()
        return snapshot_to_payload(core.snapshot(fields))

    def _metrics(self, session: Session | None, identity: bytes, message: dict[str, Any]) -> dict[str, Any]:
        core = self._need_core(session)
        groups = message.get("groups")
        if groups is not None and not all(isinstance(g, str) for g in groups):
            raise ProtocolError("metrics: groups must be a list of strings")
        return {"metrics": core.metrics(tuple(groups)) if groups is not None else core.metrics()}

    def _close(self, session: Session | None, identity: bytes, message: dict[str, Any]) -> dict[str, Any]:
        if session is not None:
            if session.core is not None:
                session.core.close()
            del self.sessions[identity]
            self._freed = True  # memory given back once the reply is sent
            log.info("session %s closed by its client", identity.hex())
        return {"closed": session is not None}

    def _shutdown(self, session: Session | None, identity: bytes, message: dict[str, Any]) -> dict[str, Any]:
        if not self.options.allow_shutdown:
            raise RequestError("forbidden", "shutdown is disabled on this server (start it with --allow-shutdown)")
        log.info("shutdown requested by %s", identity.hex())
        self.stop()
        return {"stopping": True}
