"""Live mode against a local HTTP server on loopback that answers like OpenSky's ``states/all``:
recorded states (the genuine REGA helicopter, re-timed), errors, timeouts, rate limiting and
broken answers. The real network is never used."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

from aamsim import Simulation
from aamsim.realtraffic import read_reports
from aamsim.realtraffic.live import LiveFeed, LiveSettings, OpenSkyClient, Pacer, credits_per_request, start_live

ROOT = Path(__file__).resolve().parents[1]
REGA = read_reports(ROOT / "tests" / "data" / "opensky" / "rega_zh.json.gz")
BOX = (47.3, 8.4, 47.5, 8.7)


class FakeOpenSky:
    """Answers GET /api/states/all following ``script`` (one entry per request, the last repeats):
    "ok" (the REGA report k seconds into its flight, k = the clock less ``start``, stamped with the
    clock), "500", "timeout" (answers after ``hang_s``), "429" (Retry-After header), "garbage"."""

    def __init__(self, script: list[str], clock=time.time, hang_s: float = 1.0):
        self.script, self.clock, self.hang_s = script, clock, hang_s
        self.start = clock()
        self.requests: list[str] = []
        fake = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 (http.server's name)
                fake.requests.append(self.path)
                action = fake.script[min(len(fake.requests), len(fake.script)) - 1]
                if action == "timeout":
                    time.sleep(fake.hang_s)
                    action = "ok"
                if action == "500":
                    self.send_error(500, "Internal Server Error")
                    return
                if action == "429":
                    self.send_response(429)
                    self.send_header("X-Rate-Limit-Retry-After-Seconds", "30")
                    self.end_headers()
                    return
                body = b"<html>maintenance</html>" if action == "garbage" else json.dumps(fake.response()).encode()
                self.send_response(200)
                self.send_header("Content-Type", "application/json")
                self.send_header("X-Rate-Limit-Remaining", "399")
                self.end_headers()
                try:
                    self.wfile.write(body)
                except BrokenPipeError:  # the client timed out and left
                    pass

            def log_message(self, *args: object) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/api"

    def response(self) -> dict:
        now = int(self.clock())
        k = min(max(now - int(self.start), 0), len(REGA) - 1)
        state = ["4b43ac", "REGA1   ", "Switzerland", now, now, REGA.lon[k], REGA.lat[k], REGA.alt_m[k], False,
                 REGA.gs_mps[k], REGA.trk_deg[k], REGA.vs_mps[k], None, None, None, False, 0]
        return {"time": now, "states": [state]}

    def __enter__(self) -> FakeOpenSky:
        threading.Thread(target=self.server.serve_forever, daemon=True).start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.shutdown()
        self.server.server_close()


class Clock:
    def __init__(self, t: float = 1_700_000_000.0):
        self.t = t

    def __call__(self) -> float:
        return self.t


def test_feed_survives_errors_timeouts_rate_limit_and_garbage():
    clock = Clock()
    script = ["ok", "ok", "500", "timeout", "429", "garbage", "ok", "ok"]
    with FakeOpenSky(script, clock=clock, hang_s=1.0) as server:
        messages: list[tuple[str, str]] = []
        settings = LiveSettings(api_url=server.url, interval_s=10.0, timeout_s=0.3)
        feed = LiveFeed(OpenSkyClient(BOX, settings), clock=clock, report=lambda k, t: messages.append((k, t)))
        assert feed.interval_s == 10.0 and feed.delay_s == 25.0
        times = []
        for step in range(0, 200, 5):
            clock.t = 1_700_000_000.0 + step
            before = len(server.requests)
            feed.tracks_at(clock.t - feed.delay_s)
            assert feed.wait_idle(30.0)  # polls run in the background; their results are taken at the next call
            if len(server.requests) > before:
                times.append(step)
        texts = [t for _, t in messages]
        assert any("HTTP 500" in t for t in texts)
        assert any("no answer within 0.3 s" in t for t in texts)
        assert any("rate limit reached (HTTP 429)" in t and "next try in 30 s" in t for t in texts)
        assert any("not JSON" in t for t in texts)
        assert any("answers again" in t for k, t in messages if k == "note")
        # Polls every 10 s, then backing off: 500 -> 10 s, timeout -> 20 s, 429 -> the 30 s it asked for.
        assert times[:6] == [0, 10, 20, 30, 50, 80], times
        assert feed.client.remaining_credits == 399
        tracks = feed.tracks_at(clock.t)
        assert list(tracks.icao24) == ["4b43ac"] and list(tracks.callsign) == ["REGA1"]


def test_unreachable_server_is_a_message_not_a_crash():
    with FakeOpenSky(["ok"]) as server:
        url = server.url
    sim = Simulation(dt=0.5)
    sim.services.start()
    replay = start_live(sim, BOX, LiveSettings(api_url=url, interval_s=0.2, timeout_s=0.3))
    assert replay.feed.wait_idle(30.0)  # type: ignore[attr-defined]  # the first poll, in the background
    sim.run_until(1.0)
    warnings = [str(m) for m in sim.reporter.messages if m.kind == "warning"]
    assert len(warnings) == 1 and "unreachable" in warnings[0] and "the simulation goes on" in warnings[0]
    assert sim.view.n == 0


def test_pacer_holds_sim_time_to_the_wall_clock():
    wall = Clock(100.0)
    slept: list[float] = []
    pacer = Pacer(clock=wall, sleep=lambda s: slept.append(s))

    class FakeSim:
        simt = 10.0

    sim = FakeSim()
    pacer(sim)  # type: ignore[arg-type]
    sim.simt, wall.t = 12.0, 100.5
    pacer(sim)  # type: ignore[arg-type]
    sim.simt, wall.t = 13.0, 103.5
    pacer(sim)  # type: ignore[arg-type]  # 0.5 s behind the wall clock: no sleep
    assert slept == [1.5] and pacer.restarts == 0
    sim.simt, wall.t = 14.0, 110.0
    notes: list[str] = []
    sim.note_once = lambda key, text: notes.append(text)  # type: ignore[attr-defined]
    pacer(sim)  # type: ignore[arg-type]  # 6 s behind: pacing starts again from here
    sim.simt, wall.t = 15.0, 110.25
    pacer(sim)  # type: ignore[arg-type]
    assert slept == [1.5, 0.75] and pacer.restarts == 1 and "fell 6.0 s behind" in notes[0]


def test_credits_per_request_follow_the_documented_box_sizes():
    assert credits_per_request((47.0, 8.0, 48.0, 9.0)) == 1
    assert credits_per_request((40.0, 0.0, 50.0, 10.0)) == 2  # 100 sq deg: the 25-100 tier
    assert credits_per_request((40.0, 0.0, 51.0, 10.0)) == 3
    assert credits_per_request((30.0, 0.0, 50.0, 30.0)) == 4


def test_account_uses_oauth2_client_credentials_token():
    tokens: list[bytes] = []
    seen: list[str] = []

    class Handler(BaseHTTPRequestHandler):
        def do_POST(self) -> None:  # noqa: N802
            tokens.append(self.rfile.read(int(self.headers["Content-Length"])))
            body = json.dumps({"access_token": "tok123", "expires_in": 1800}).encode()
            self.send_response(200)
            self.end_headers()
            self.wfile.write(body)

        def do_GET(self) -> None:  # noqa: N802
            seen.append(self.headers.get("Authorization", ""))
            body = json.dumps({"time": 1, "states": None}).encode()
            self.send_response(200)
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args: object) -> None:
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        base = f"http://127.0.0.1:{server.server_address[1]}"
        settings = LiveSettings.from_env({"AAMSIM_OPENSKY_URL": base + "/api", "AAMSIM_OPENSKY_TOKEN_URL": base + "/t",
                                          "OPENSKY_CLIENT_ID": "me", "OPENSKY_CLIENT_SECRET": "s3cret"})
        assert settings.account and settings.poll_interval_s == 5.0
        client = OpenSkyClient(BOX, settings)
        assert len(client.poll().reports) == 0 and len(client.poll().reports) == 0
    finally:
        server.shutdown()
        server.server_close()
    assert tokens == [b"grant_type=client_credentials&client_id=me&client_secret=s3cret"]  # one token, reused
    assert seen == ["Bearer tok123", "Bearer tok123"]


def run_cli(args: list[str], env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "aamsim", *args], capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, PYTHONPATH=str(ROOT), **env))


@pytest.fixture
def hover_scenario(tmp_path: Path) -> Iterator[Path]:
    scn = tmp_path / "hover.scn"
    scn.write_text("00:00:00.00>CRE UAM1 EC35 47.37 8.55 0 2000 0\n")
    yield scn


def test_run_overlay_opensky_live_on_loopback(tmp_path, hover_scenario):
    """aamsim run --overlay opensky:...: paced to real time, the helicopter appears once two polls framed it."""
    with FakeOpenSky(["ok", "500", "ok"]) as server:
        out = tmp_path / "live"
        t0 = time.monotonic()
        proc = run_cli(["run", str(hover_scenario), "--until", "8", "--out", str(out), "--log-period", "1",
                        "--overlay", "opensky:" + ",".join(map(str, BOX))],
                       {"AAMSIM_OPENSKY_URL": server.url, "AAMSIM_OPENSKY_INTERVAL_S": "0.5"})
        wall = time.monotonic() - t0
    assert proc.returncode == 0, proc.stderr
    assert "HTTP 500" in proc.stderr and "the simulation goes on" in proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sim_time_s"] == pytest.approx(8.0)
    assert summary["wall_time_s"] >= 7.5 and wall >= 7.5  # paced: 8 s of sim time took at least 8 s
    assert summary["real_traffic"][0]["aircraft_replayed"] == 1
    rows = (out / "trajectories.csv").read_text().splitlines()
    assert any("RT4B43AC" in r for r in rows)
    # Polling went on after the 500 (how many polls fit in 8 s depends on the machine's load and
    # on the back-off after the error; the three scripted answers must all have been asked for).
    assert len(server.requests) >= 3


def test_run_overlay_opensky_unreachable(tmp_path, hover_scenario):
    with FakeOpenSky(["ok"]) as server:
        url = server.url  # closed when the run starts
    proc = run_cli(["run", str(hover_scenario), "--until", "2", "--out", str(tmp_path / "o"),
                    "--overlay", "opensky:" + ",".join(map(str, BOX))], {"AAMSIM_OPENSKY_URL": url})
    assert proc.returncode == 0, proc.stderr
    assert "unreachable" in proc.stderr
