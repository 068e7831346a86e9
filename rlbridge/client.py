"""Client side of the simulation server: :class:`RemoteEpisode` mirrors :class:`~rlbridge.core.EpisodeCore`.

Every request waits at most ``timeout_s`` for its reply. When none comes (the
server died, is unreachable or overloaded) the client raises
:class:`ServerUnavailable`, naming the address and the timeout, and replaces
its socket (closed with linger 0), so that a stale reply can never be taken
for the answer to a later request. The server keeps a session per socket, so
after a timeout the episode must be reset. Error replies raise
:class:`RemoteError` with the server's message.
"""

from __future__ import annotations

import os
import time
import weakref
from pathlib import Path
from typing import Any, Self

import zmq

from aamsim.snapshots import SNAPSHOT_FIELDS, TrafficSnapshot
from rlbridge.core import TRAFFIC_STATE_FIELDS, StepResult
from rlbridge.protocol import DEFAULT_MAX_MESSAGE_BYTES, PROTOCOL_VERSION, ProtocolError, decode, request
from rlbridge.wire import actions_to_payload, snapshot_from_payload, step_result_from_payload


class ServerUnavailable(ConnectionError):
    """No reply from the simulation server within the timeout."""


class RemoteError(RuntimeError):
    """The server answered with an error reply; ``code`` is its error code."""

    def __init__(self, message: str, code: str = "error"):
        super().__init__(message)
        self.code = code


class _Held:
    """A connection's context and current socket; released by a finalizer if never closed."""

    def __init__(self) -> None:
        self.context = zmq.Context()
        self.socket: zmq.Socket | None = None

    def release(self) -> None:
        if self.socket is not None:
            self.socket.close(0)  # linger 0: never blocks
        self.context.term()


class Connection:
    """A DEALER socket to one server: one request, one reply, each within ``timeout_s``."""

    def __init__(self, address: str, timeout_s: float = 30.0, max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES):
        if not timeout_s > 0:
            raise ValueError("timeout_s must be positive")
        self.address = address
        self.timeout_s = float(timeout_s)
        self.max_message_bytes = max_message_bytes
        self._next_id = 1
        self._held = _Held()
        self._release = weakref.finalize(self, self._held.release)
        try:
            self._held.socket = self._new_socket()
        except ValueError:
            self._release()
            raise

    @property
    def _socket(self) -> zmq.Socket:
        assert self._held.socket is not None
        return self._held.socket

    def _new_socket(self) -> zmq.Socket:
        sock = self._held.context.socket(zmq.DEALER)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.ROUTING_ID, os.urandom(16))  # the server keys our session by it
        sock.setsockopt(zmq.MAXMSGSIZE, 2 * self.max_message_bytes + 65536)
        try:
            sock.connect(self.address)
        except zmq.ZMQError as exc:
            sock.close(0)
            raise ValueError(f"cannot connect to {self.address!r}: {exc}") from None
        return sock

    def _reset_socket(self) -> None:
        self._socket.close(0)
        self._held.socket = None
        self._held.socket = self._new_socket()

    def call(self, op: str, **fields: Any) -> dict[str, Any]:
        """Send one request and return the reply's fields; raises on timeout or an error reply."""
        if self.closed:
            raise ServerUnavailable(f"connection to {self.address} is closed")
        msg_id = self._next_id
        self._next_id += 1
        frames = request(op, msg_id, **fields)
        try:
            self._socket.send_multipart(frames, flags=zmq.NOBLOCK, copy=False)
        except zmq.Again:
            self._reset_socket()
            raise ServerUnavailable(f"cannot send {op!r} to {self.address}: queue full") from None
        deadline = time.monotonic() + self.timeout_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not self._socket.poll(max(1, int(remaining * 1000)), zmq.POLLIN):
                self._reset_socket()
                raise ServerUnavailable(f"no reply from the simulation server at {self.address} within "
                                        f"{self.timeout_s:g} s to {op!r} (is it running and reachable?)")
            reply = decode(self._socket.recv_multipart(copy=False), self.max_message_bytes)
            if reply.get("id") == msg_id:
                break  # anything else is a late reply to an earlier request: skip it
        if reply.get("ok") is True:
            return reply
        if reply.get("ok") is False:
            raise RemoteError(str(reply.get("error", "unspecified error")), str(reply.get("code", "error")))
        raise ProtocolError("reply without a boolean 'ok'")

    def close(self) -> None:
        self._release()  # runs once

    @property
    def closed(self) -> bool:
        return not self._release.alive


class RemoteEpisode:
    """An :class:`~rlbridge.core.EpisodeCore` that runs in a simulation server.

    Same constructor arguments (plus the server ``address`` and ``timeout_s``),
    same attributes and methods, same :class:`~rlbridge.core.StepResult`
    arrays, bit for bit. The scenario name is resolved by the server (its
    scenario roots and the shipped scenarios).
    """

    def __init__(
        self,
        address: str,
        scenario: str | Path,
        usecase: str = "corridor_sa",
        params: dict[str, Any] | None = None,
        time_limit_s: float | None = None,
        dt: float = 0.05,
        timeout_s: float = 30.0,
    ):
        if not isinstance(usecase, str):
            raise TypeError("a remote episode takes a use case by name (the server instantiates it)")
        self.address = address
        self.scenario = str(scenario)
        self.usecase_name = usecase
        self.params = dict(params or {})
        self.dt = dt
        self._requested_time_limit_s = time_limit_s
        self.connection = Connection(address, timeout_s)
        self.agents: list[str] = []
        self.seed: int | None = None
        self._session = False  # the server holds a session (an opened scenario) for our socket
        self._ready = False  # reset() has run in that session
        # Whether the server's step results carry the action targets (EpisodeCore.publish_targets),
        # sent with each reset.
        self.publish_targets = False
        try:
            hello = self.connection.call("hello", client="rlbridge")
            if hello.get("protocol") != PROTOCOL_VERSION:
                raise RemoteError(f"server at {address} speaks protocol {hello.get('protocol')!r}, "
                                  f"not {PROTOCOL_VERSION}", "version")
            self._open()
        except BaseException:
            self.connection.close()
            raise

    def _open(self) -> None:
        opened = self.connection.call("open", **self._open_fields())
        self._take_open_reply(opened)
        self._session = True

    def _open_fields(self) -> dict[str, Any]:
        return {"scenario": self.scenario, "usecase": self.usecase_name, "params": self.params,
                "time_limit_s": self._requested_time_limit_s, "dt": float(self.dt)}

    def _take_open_reply(self, opened: dict[str, Any]) -> None:
        self.possible_agents: list[str] = list(opened["possible_agents"])
        self.parse_errors: list[str] = list(opened["parse_errors"])
        self.time_limit_s: float = float(opened["time_limit_s"])
        self.server_path = str(opened["scenario"])

    def _call(self, op: str, **fields: Any) -> dict[str, Any]:
        try:
            return self.connection.call(op, **fields)
        except ServerUnavailable:
            self._session = self._ready = False  # the socket (and with it the server session) was replaced
            raise
        except RemoteError as exc:
            if exc.code == "no_session":  # the server freed it (idle timeout) or restarted
                self._session = self._ready = False
            raise

    # --------------------------------------------------------------------- API
    def reset(self, seed: int | None = None) -> StepResult:
        fields: dict[str, Any] = {"seed": None if seed is None else int(seed)}
        if self.publish_targets:  # only then: a server from before the field knows none
            fields["targets"] = True
        if not self._session:
            fields.update(self._open_fields())  # reopen: a fresh socket has no session yet
        try:
            payload = self._call("reset", **fields)
        except RemoteError as exc:
            if exc.code != "no_session":
                raise
            fields.update(self._open_fields())
            payload = self._call("reset", **fields)
        if "possible_agents" in payload:
            self._take_open_reply(payload)
        result = step_result_from_payload(payload)
        self._session = self._ready = True
        self.seed = seed
        self.agents = list(result.alive)
        return result

    def step(self, actions: dict[str, Any]) -> StepResult:
        if not self._ready:
            raise RuntimeError("step() before reset() (or the session was lost after a timeout: reset again)")
        result = step_result_from_payload(self._call("step", **actions_to_payload(actions)))
        self.agents = list(result.alive)
        return result

    def metrics(self, groups: tuple[str, ...] = ("safety", "operational")) -> dict[str, Any]:
        if not self._ready:
            return {}
        return dict(self._call("metrics", groups=list(groups))["metrics"])

    def stack(self, text: str) -> list[str]:
        if not self._ready:
            raise RuntimeError("stack() before reset()")
        return list(self._call("stack", text=text)["messages"])

    def traffic_state(self) -> dict[str, Any]:
        if not self._ready:
            raise RuntimeError("traffic_state() before reset()")
        state = self._call("state")
        return {k: state[k] for k in ("simt", "ids", *TRAFFIC_STATE_FIELDS)}

    def snapshot(self, fields: tuple[str, ...] = SNAPSHOT_FIELDS) -> TrafficSnapshot:
        """A frozen copy of the server's traffic now, ``fields`` only (float64, bit for bit the server's)."""
        if not self._ready:
            raise RuntimeError("snapshot() before reset()")
        return snapshot_from_payload(self._call("state", fields=list(fields)))

    def close(self) -> None:
        """Free the server session (best effort) and close the socket."""
        if self.connection.closed:
            return
        try:
            self.connection.timeout_s = min(self.connection.timeout_s, 1.0)
            self.connection.call("close")
        except (ServerUnavailable, RemoteError, ProtocolError):
            pass  # the server is gone or forgot us: nothing left to free
        finally:
            self.connection.close()
            self.agents = []
            self._session = self._ready = False

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
