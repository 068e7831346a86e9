"""The live OpenSky client against hostile servers on loopback (issue 26 item 4): redirects to another
host (with an account's bearer token), huge answers, and servers that trickle a byte at a time.

Real ``http.server`` servers on 127.0.0.1 and ``localhost``; the HTTP client is not mocked.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Self

import pytest

from aamsim.realtraffic.live import LiveSettings, OpenSkyClient

ROOT = Path(__file__).resolve().parents[1]
BOX = (47.3, 8.4, 47.5, 8.7)
STATES = json.dumps({"time": 1, "states": []}).encode()


class Hostile:
    """A server whose answer to every request is ``behaviour`` (see :meth:`answer`); records what it saw."""

    def __init__(self, behaviour: str, *, location: str = "", size: int = 0, trickle_s: float = 0.5,
                 trickle_n: int = 60):
        self.behaviour, self.location, self.size = behaviour, location, size
        self.trickle_s, self.trickle_n = trickle_s, trickle_n
        self.requests: list[tuple[str, str, str]] = []  # method, path, Authorization
        self.sent = 0  # body bytes the client took
        self.trickle_done = threading.Event()  # a trickle ran to its end (the client waited for all of it)
        self.trickle_started = threading.Event()
        host = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def do_GET(self) -> None:  # http.server's name
                host.requests.append(("GET", self.path, self.headers.get("Authorization", "")))
                host.answer(self)

            def do_POST(self) -> None:
                length = int(self.headers.get("Content-Length") or 0)
                self.rfile.read(length)
                host.requests.append(("POST", self.path, self.headers.get("Authorization", "")))
                if self.path == "/token":
                    body = json.dumps({"access_token": "tok123", "expires_in": 1800}).encode()
                    self.send_response(200)
                    self.send_header("Content-Length", str(len(body)))
                    self.end_headers()
                    self.wfile.write(body)
                    return
                host.answer(self)

            def log_message(self, *args: object) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.server.block_on_close = False  # closing never waits for a handler still trickling
        self.port = self.server.server_address[1]

    def url(self, host: str = "127.0.0.1") -> str:
        return f"http://{host}:{self.port}"

    def answer(self, handler: BaseHTTPRequestHandler) -> None:
        try:
            if self.behaviour == "redirect" and not handler.path.startswith("/moved"):
                handler.send_response(302)
                handler.send_header("Location", self.location)
                handler.send_header("Content-Length", "0")
                handler.end_headers()
            elif self.behaviour == "declared-huge":
                handler.send_response(200)
                handler.send_header("Content-Length", str(self.size))
                handler.end_headers()
                self._stream(handler)
            elif self.behaviour == "huge":  # no length: the body ends when the connection closes
                handler.send_response(200)
                handler.send_header("Connection", "close")
                handler.end_headers()
                self._stream(handler)
            elif self.behaviour in ("trickle", "trickle-headers"):
                self.trickle_started.set()
                if self.behaviour == "trickle":
                    handler.send_response(200)
                    handler.send_header("Content-Length", str(self.trickle_n))
                    handler.end_headers()
                else:
                    handler.wfile.write(b"HTTP/1.1 200 OK\r\nX-Slow: ")
                for _ in range(self.trickle_n):
                    handler.wfile.write(b" ")
                    handler.wfile.flush()
                    time.sleep(self.trickle_s)
                self.trickle_done.set()
            else:
                body = b"[" * 100_000 if self.behaviour == "nested" else STATES
                handler.send_response(200)
                handler.send_header("Content-Length", str(len(body)))
                handler.end_headers()
                handler.wfile.write(body)
        except (BrokenPipeError, ConnectionResetError):
            pass  # the client gave up

    def _stream(self, handler: BaseHTTPRequestHandler) -> None:
        block = b" " * (1 << 20)  # JSON whitespace: a client that reads it all finds no value at the end
        while self.sent < self.size:
            handler.wfile.write(block)
            self.sent += len(block)

    def __enter__(self) -> Self:
        threading.Thread(target=self.server.serve_forever, daemon=True).start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.shutdown()
        self.server.server_close()


def account(api: str, token: str, **kw: object) -> LiveSettings:
    return LiveSettings(api_url=api, token_url=token, client_id="me", client_secret="s3cret", **kw)  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------------ redirects
def test_a_redirect_to_another_host_is_not_followed_and_the_token_stays_home():
    # "localhost" and another port: another origin than 127.0.0.1:<port> (either alone would do).
    with Hostile("ok") as evil, Hostile("redirect", location=evil.url("localhost") + "/steal") as home:
        client = OpenSkyClient(BOX, account(home.url() + "/api", home.url() + "/token"))
        result = client.poll()
    assert result.reports is None
    assert "redirected (HTTP 302) to another host" in result.problem and "not followed" in result.problem
    assert evil.requests == []  # nothing reached it, and so no "Bearer tok123"
    assert [r[2] for r in home.requests if r[0] == "GET"] == ["Bearer tok123"]


def test_a_redirected_token_request_is_not_followed():
    # The token URL answers with a redirect to the other server (whose /token would answer).
    with Hostile("ok") as evil, Hostile("redirect", location=evil.url() + "/token") as home:
        client = OpenSkyClient(BOX, account(home.url() + "/api", home.url() + "/auth"))
        result = client.poll()
    assert result.reports is None and "not followed" in result.problem
    assert evil.requests == []


def test_a_redirect_on_the_same_host_is_followed_with_the_token():
    with Hostile("redirect") as home:
        home.location = home.url() + "/moved/states/all"
        client = OpenSkyClient(BOX, account(home.url() + "/api", home.url() + "/token"))
        result = client.poll()
    assert result.reports is not None and len(result.reports) == 0, result.problem
    gets = [r for r in home.requests if r[0] == "GET"]
    assert [r[1].split("?")[0] for r in gets] == ["/api/states/all", "/moved/states/all"]
    assert {r[2] for r in gets} == {"Bearer tok123"}


# ------------------------------------------------------------------------------------------ sizes
@pytest.mark.parametrize("behaviour", ["declared-huge", "huge"])
def test_an_answer_over_the_size_cap_is_not_read(behaviour):
    cap = 1 << 20
    with Hostile(behaviour, size=400 << 20) as server:
        client = OpenSkyClient(BOX, LiveSettings(api_url=server.url() + "/api", max_body_bytes=cap))
        result = client.poll()
    assert result.reports is None
    assert "bytes accepted" in result.problem
    # The server could hand over its 400 MB only as fast as the client read: it stopped after the cap
    # (plus what the sockets' buffers hold).
    assert server.sent < 64 << 20


def test_a_400_mb_answer_does_not_grow_the_process():
    """The issue's measurement (400 MB answer: 975 MB resident), in a fresh process with the default cap."""
    with Hostile("huge", size=400 << 20) as server:
        code = (
            "import resource, sys\n"
            "from aamsim.realtraffic.live import LiveSettings, OpenSkyClient\n"
            "client = OpenSkyClient((47.3, 8.4, 47.5, 8.7), LiveSettings(api_url=sys.argv[1]))\n"
            "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
            "result = client.poll()\n"
            "after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
            "print((after - before) // 1024, result.problem)\n"
        )
        proc = subprocess.run([sys.executable, "-c", code, server.url() + "/api"], capture_output=True, text=True,
                              timeout=600, env=dict(os.environ, PYTHONPATH=str(ROOT)), check=False)
    assert proc.returncode == 0, proc.stderr
    grown_mb, problem = proc.stdout.split(" ", 1)
    assert "bytes accepted" in problem
    assert int(grown_mb) < 100  # the 16 MiB cap, read in 64 KiB chunks


def test_an_answer_nested_thousands_deep_is_not_json_not_a_crash():
    with Hostile("nested") as server:
        result = OpenSkyClient(BOX, LiveSettings(api_url=server.url() + "/api")).poll()
    assert result.reports is None and result.problem.startswith("not JSON (RecursionError")


# ------------------------------------------------------------------------------------------ trickles
@pytest.mark.parametrize("behaviour", ["trickle", "trickle-headers"])
def test_a_trickling_server_cannot_hold_a_poll_past_its_deadline(behaviour):
    # A byte every 0.5 s never trips the 2 s socket timeout; the 2 s deadline of the whole poll ends it.
    with Hostile(behaviour, trickle_s=0.5, trickle_n=60) as server:
        client = OpenSkyClient(BOX, LiveSettings(api_url=server.url() + "/api", timeout_s=2.0, deadline_s=2.0))
        result = client.poll()
        still_trickling = not server.trickle_done.is_set()
    assert result.reports is None and result.problem == "no complete answer within 2 s"
    assert still_trickling  # the poll ended while the server was still at it (30 s of trickle)


def hover(tmp_path: Path) -> Path:
    scn = tmp_path / "hover.scn"
    scn.write_text("00:00:00.00>CRE UAM1 EC35 47.37 8.55 0 2000 0\n")
    return scn


def live_run(tmp_path: Path, server: Hostile, until: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "aamsim", "run", str(hover(tmp_path)), "--until", until, "--out",
         str(tmp_path / "out"), "--overlay", "opensky:" + ",".join(map(str, BOX))],
        env=dict(os.environ, PYTHONPATH=str(ROOT), AAMSIM_OPENSKY_URL=server.url() + "/api",
                 AAMSIM_OPENSKY_INTERVAL_S="0.5"),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_a_trickling_server_does_not_keep_the_run_past_until(tmp_path):
    # A byte every 3 s for 3 minutes (the server). The run is paced to real time: 3 s of
    # sim time. It ends while the server still trickles: the poll never held up the simulation.
    with Hostile("trickle", trickle_s=3.0, trickle_n=60) as server:
        proc = live_run(tmp_path, server, "3")
        _, err = proc.communicate(timeout=600)
        still_trickling = not server.trickle_done.is_set()
    assert proc.returncode == 0, err
    assert server.trickle_started.is_set() and still_trickling
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["sim_time_s"] == pytest.approx(3.0)


def test_sigterm_ends_a_live_run_while_the_server_trickles(tmp_path):
    with Hostile("trickle", trickle_s=3.0, trickle_n=60) as server:
        proc = live_run(tmp_path, server, "600")
        assert server.trickle_started.wait(300), "the run never polled"
        # Wait until the run steps (its provisional summary shows sim time going on) while the poll
        # hangs on the trickle; no limit is asserted on how long that takes.
        summary_path = tmp_path / "out" / "summary.json"
        for _ in range(3000):
            try:
                if json.loads(summary_path.read_text())["sim_time_s"] > 0:
                    break
            except (OSError, ValueError):
                pass
            assert proc.poll() is None, proc.communicate()[1]
            time.sleep(0.1)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=600)
        still_trickling = not server.trickle_done.is_set()
    assert proc.returncode == 143, err
    assert still_trickling  # SIGTERM was handled at once, not after the poll
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["interrupted_by"] == "SIGTERM" and summary["complete"] is True
