"""Bounded HTTP requests for the live OpenSky client: same-origin redirects, a size cap, a total deadline.

``urllib`` alone follows redirects to any host with every header of the
request (an OAuth bearer token included), reads a body of any size and only
times out a single socket operation, so a server that sends a byte every few
seconds holds a request for ever. Here:

* a redirect is followed only within the origin of the request (scheme, host
  and port), at most :data:`MAX_REDIRECTS` times; one to anywhere else is
  refused (:class:`RedirectRefused`), so credentials never leave the host
  they were meant for;
* a body larger than ``max_bytes`` is refused: at once when its
  ``Content-Length`` says so, otherwise as soon as that many bytes came
  (:class:`TooLarge`); the body is read in chunks, never whole;
* the whole request (connection, redirects, headers, body) has a deadline:
  when it passes, a watchdog shuts the socket down, which ends any read in
  progress (:class:`DeadlineExceeded`), however slowly the server trickles.

Proxies from the environment are used as by ``urllib``.
"""

from __future__ import annotations

import http.client
import socket
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass
from email.message import Message
from typing import Any

MAX_REDIRECTS = 3
_CHUNK = 64 * 1024


class FetchProblem(urllib.error.URLError):
    """A request given up for a reason of this module (its text says which)."""

    def __init__(self, problem: str):
        super().__init__(problem)
        self.problem = problem


class RedirectRefused(FetchProblem):
    pass


class TooLarge(FetchProblem):
    pass


class DeadlineExceeded(FetchProblem):
    pass


@dataclass(frozen=True)
class Answer:
    status: int
    headers: Message
    body: bytes


def origin(url: str) -> tuple[str, str, int | None]:
    """(scheme, host, port) of a URL, the port made explicit."""
    parts = urllib.parse.urlsplit(url)
    scheme = parts.scheme.lower()
    port = parts.port or {"http": 80, "https": 443}.get(scheme)
    return scheme, (parts.hostname or "").lower(), port


class _Watch:
    """The connections of one request, shut down together when its deadline passes."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.connections: list[http.client.HTTPConnection] = []
        self.expired = False

    def add(self, connection: http.client.HTTPConnection) -> None:
        with self.lock:
            self.connections.append(connection)

    def expire(self) -> None:
        with self.lock:
            self.expired = True
            for connection in self.connections:
                sock = connection.sock
                if sock is not None:
                    try:
                        sock.shutdown(socket.SHUT_RDWR)  # wakes up a recv blocked in another thread
                    except OSError:
                        pass


class _SameOriginRedirects(urllib.request.HTTPRedirectHandler):
    max_redirections = MAX_REDIRECTS

    def __init__(self, allowed: tuple[str, str, int | None]):
        self.allowed = allowed

    def redirect_request(self, req: urllib.request.Request, fp: Any, code: int, msg: str, headers: Any,
                         newurl: str) -> urllib.request.Request | None:
        if origin(newurl) != self.allowed:
            scheme, host, port = origin(newurl)
            raise RedirectRefused(f"redirected (HTTP {code}) to another host, {scheme}://{host}:{port}; not followed")
        return super().redirect_request(req, fp, code, msg, headers, newurl)


class _WatchedHTTP(urllib.request.HTTPHandler):
    def __init__(self, watch: _Watch):
        super().__init__()
        self.watch = watch

    def http_open(self, req: urllib.request.Request) -> http.client.HTTPResponse:
        def connect(host: str, **kwargs: Any) -> http.client.HTTPConnection:
            connection = http.client.HTTPConnection(host, **kwargs)
            self.watch.add(connection)
            return connection

        return self.do_open(connect, req)  # type: ignore[arg-type]


class _WatchedHTTPS(urllib.request.HTTPSHandler):
    def __init__(self, watch: _Watch):
        super().__init__()
        self.watch = watch

    def https_open(self, req: urllib.request.Request) -> http.client.HTTPResponse:
        def connect(host: str, **kwargs: Any) -> http.client.HTTPSConnection:
            connection = http.client.HTTPSConnection(host, **kwargs)
            self.watch.add(connection)
            return connection

        return self.do_open(connect, req, context=self._context)  # type: ignore[arg-type,attr-defined]


def fetch(url: str, *, headers: dict[str, str], data: bytes | None = None, timeout_s: float, deadline_s: float,
          max_bytes: int) -> Answer:
    """One bounded request (see the module docstring).

    Args:
        timeout_s: limit of each socket operation [s].
        deadline_s: limit of the whole request [s].
        max_bytes: the largest body accepted [bytes].

    Raises:
        urllib.error.HTTPError: an HTTP error status (its headers say e.g. when to retry).
        FetchProblem: a redirect off the origin, a body over ``max_bytes``, the deadline passed.
        urllib.error.URLError, OSError, TimeoutError: the network failed.
    """
    watch = _Watch()
    opener = urllib.request.build_opener(_SameOriginRedirects(origin(url)), _WatchedHTTP(watch), _WatchedHTTPS(watch))
    timer = threading.Timer(deadline_s, watch.expire)
    timer.daemon = True  # never keeps the process alive
    timer.start()
    end = time.monotonic() + deadline_s
    try:
        with opener.open(urllib.request.Request(url, data=data, headers=headers), timeout=timeout_s) as answer:
            length = answer.headers.get("Content-Length")
            if length is not None and length.strip().isdigit() and int(length) > max_bytes:
                raise TooLarge(f"answer of {int(length):,} bytes, over the {max_bytes:,} bytes accepted; not read")
            body = bytearray()
            while True:
                chunk = answer.read1(_CHUNK)
                if not chunk:
                    break
                body += chunk
                if len(body) > max_bytes:
                    raise TooLarge(f"answer over the {max_bytes:,} bytes accepted; reading stopped")
                if time.monotonic() > end:
                    raise DeadlineExceeded(f"no complete answer within {deadline_s:g} s")
            if watch.expired:  # the shutdown ended the body early: it is not the whole answer
                raise DeadlineExceeded(f"no complete answer within {deadline_s:g} s")
            return Answer(answer.status, answer.headers, bytes(body))
    except (OSError, http.client.HTTPException) as err:
        if watch.expired and not isinstance(err, (FetchProblem, urllib.error.HTTPError)):
            raise DeadlineExceeded(f"no complete answer within {deadline_s:g} s") from None
        if isinstance(err, http.client.HTTPException):
            raise urllib.error.URLError(f"broken answer ({type(err).__name__})") from None
        raise
    finally:
        timer.cancel()
        watch.expire()  # closes what is left (a refused redirect's connection, an unread body)
