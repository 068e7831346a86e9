"""The web viewer in a real browser: headless Chromium (Playwright) against `aamsim view` and `aamsim run --view`.

Skips only when no Chromium is installed (on Debian: ``apt-get install chromium``; ``.ci/run`` installs it).
Screenshots are written to the test's folder, and also to ``$AAMSIM_SCREENSHOT_DIR`` when set.
"""

from __future__ import annotations

import csv
import os
import queue
import re
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

playwright_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install -e .[test])")


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        found = shutil.which(name)
        if found:
            return found
    return None


CHROMIUM = _chromium()
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on PATH (Debian: apt-get install chromium)")

# Three aircraft on long straight routes between two vertiports: none lands within the test.
SCENARIO = """\
00:00:00.00>DEFWPT VA 40.70 -74.02
00:00:00.00>DEFWPT VB 40.80 -73.92
00:00:00.00>CRE U1 EC35 40.70 -74.02 35 1000 60
00:00:00.00>ORIG U1 VA
00:00:00.00>DEST U1 VB
00:00:00.00>CRE U2 EC35 40.80 -73.92 215 1000 60
00:00:00.00>ORIG U2 VB
00:00:00.00>DEST U2 VA
00:01:00.00>CRE U3 EC35 40.75 -74.05 90 1500 60
00:01:00.00>ADDWPT U3 40.75 -73.90
"""


def _aamsim(*args: str) -> list[str]:
    return [sys.executable, "-m", "aamsim", *args]


class _Server:
    """A viewer process whose output is read all along (by a thread), so that it never blocks on a full
    pipe, and kept for the message of a failing stop."""

    def __init__(self, cmd: list[str], cwd: Path) -> None:
        # faulthandler: a process that does not stop is made to print every thread's stack (SIGABRT below).
        env = dict(os.environ, PYTHONFAULTHANDLER="1")
        self.proc = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                     env=env)
        self.lines: list[str] = []
        self.url: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.lines.append(line)
            m = re.search(r"viewer: (http://127\.0\.0\.1:\d+/(?:\?token=[\w-]+)?)", line)
            if m:
                self.url.put(m.group(1))
        self.url.put(None)  # the process closed its stderr: it ended

    def send_signal(self, sig: int) -> None:
        self.proc.send_signal(sig)

    def wait(self, timeout: float) -> int:
        return self.proc.wait(timeout)

    def poll(self) -> int | None:
        return self.proc.poll()


def _start(cmd: list[str], cwd: Path) -> tuple[_Server, str]:
    """Start a viewer process and read its URL from what it prints."""
    server = _Server(cmd, cwd)
    url = server.url.get(timeout=300)
    if url is None:
        server.wait(10)
        raise AssertionError(f"no viewer URL printed; exit {server.poll()}:\n{''.join(server.lines)[-3000:]}")
    return server, url


def _stop(server: _Server) -> int:
    server.send_signal(signal.SIGINT)
    try:
        return server.wait(120)  # a loaded machine may take long to stop; a hang still fails
    except subprocess.TimeoutExpired:
        server.send_signal(signal.SIGABRT)  # faulthandler prints where every thread is
        try:
            server.wait(20)
        except subprocess.TimeoutExpired:
            pass
        raise AssertionError("the viewer did not stop within 120 s of Ctrl-C; what it printed, its threads' "
                             f"stacks last:\n{''.join(server.lines)[-8000:]}") from None
    finally:
        if server.poll() is None:
            server.proc.kill()


def _screenshot(page, tmp_path: Path, name: str) -> Path:
    path = tmp_path / name
    page.screenshot(path=str(path))
    extra = os.environ.get("AAMSIM_SCREENSHOT_DIR")
    if extra:
        Path(extra).mkdir(parents=True, exist_ok=True)
        shutil.copy(path, Path(extra) / name)
    assert path.stat().st_size > 10_000  # a drawn page, not an empty one
    return path


def _expected_at(traj: Path, t: float) -> dict[str, tuple[float, float]]:
    with open(traj, newline="") as fh:
        return {r["id"]: (float(r["lat"]), float(r["lon"])) for r in csv.DictReader(fh) if float(r["simt"]) == t}


@pytest.fixture(scope="module")
def browser():
    with playwright_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox", "--disable-gpu"])
        yield b
        b.close()


def test_a_replay_shows_the_aircraft_of_the_moment_the_slider_picks(browser, tmp_path):
    scn = tmp_path / "three.scn"
    scn.write_text(SCENARIO)
    run = tmp_path / "run"
    done = subprocess.run(_aamsim("run", str(scn), "--until", "600", "--out", str(run), "--quiet"),
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    proc, url = _start(_aamsim("view", str(run), "--port", "0"), tmp_path)
    try:
        page = browser.new_page(viewport={"width": 1100, "height": 750})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(url)
        page.wait_for_function("Number(document.getElementById('map').dataset.frames) > 3", timeout=20_000)
        page.click("#play")  # pause
        page.wait_for_function("document.getElementById('play').textContent === 'play'", timeout=10_000)
        shown = {}
        for t in (30.0, 300.0):  # before and after U3 is created at 60 s
            page.evaluate(f"() => {{ const s = document.getElementById('slider'); s.value = '{t:g}';"
                          "s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change')); }")
            page.wait_for_function(f"document.getElementById('map').dataset.simt === '{t:g}'", timeout=10_000)
            expected = _expected_at(run / "trajectories.csv", t)
            assert page.get_attribute("#map", "data-aircraft") == str(len(expected))
            frame = page.evaluate("() => { const f = window.viewerState.frame; "
                                  "return {ids: f.ids, lat: f.lat, lon: f.lon}; }")
            got = {i: (a, o) for i, a, o in zip(frame["ids"], frame["lat"], frame["lon"])}
            assert got.keys() == expected.keys()
            for acid, (lat, lon) in expected.items():
                assert got[acid] == pytest.approx((lat, lon), abs=2e-5)  # 5 decimals sent: about 1 m
            shown[t] = got
        assert len(shown[30.0]) == 2 and len(shown[300.0]) == 3
        assert shown[300.0]["U1"][0] > shown[30.0]["U1"][0] + 0.01  # U1 flew north-east in between
        # hovering over U3 labels it (callsign, altitude 1,500 ft, route from flights.csv)
        x, y = page.evaluate("() => { const s = window.viewerState, k = s.drawnIds.findIndex("
                             "(i) => s.frame.ids[i] === 'U3'); return s.drawnXY[k]; }")
        box = page.locator("#map").bounding_box()
        page.mouse.move(box["x"] + x, box["y"] + y)
        page.wait_for_selector("#tooltip:not([hidden])", timeout=5_000)
        tip = page.text_content("#tooltip") or ""
        assert tip.startswith("U3") and "alt 1500 ft" in tip, tip
        # the altitude filter hides U3 (1,500 ft) and keeps the two at 1,000 ft
        page.fill("#alt-max", "1200")
        page.wait_for_function("document.getElementById('map').dataset.aircraft === '2'", timeout=10_000)
        page.fill("#alt-max", "60000")
        assert page.text_content("#airborne") == "3"
        _screenshot(page, tmp_path, "viewer-replay.png")
        assert errors == []
    finally:
        assert _stop(proc) == 0


def test_a_live_run_streams_its_traffic_and_keeps_the_last_picture(browser, tmp_path):
    scn = tmp_path / "three.scn"
    scn.write_text(SCENARIO)
    proc, url = _start(_aamsim("run", str(scn), "--until", "150", "--out", str(tmp_path / "run"), "--quiet",
                               "--view", "--port", "0", "--pace", "10"), tmp_path)
    try:
        page = browser.new_page(viewport={"width": 1100, "height": 750})
        page.goto(url)
        page.wait_for_function("document.getElementById('map').dataset.aircraft === '2'", timeout=20_000)
        # The time shown and the connection's state read together: at 10x the run's 150 s take 15 s, and
        # on a loaded machine the page may first draw it later than 60 s, or only after its end.
        shown = "() => [document.getElementById('map').dataset.simt, document.getElementById('connection').textContent]"
        t1, state1 = page.evaluate(shown)
        assert float(t1) < 60.0 and state1 == "live"  # U3 (created at 60 s) is not there yet: the run goes on
        page.wait_for_function("document.getElementById('map').dataset.aircraft === '3'", timeout=20_000)
        t2, _ = page.evaluate(shown)
        assert float(t2) >= 60.0 > float(t1)
        page.wait_for_function("document.getElementById('connection').textContent.includes('finished')",
                               timeout=30_000)
        assert float(page.get_attribute("#map", "data-simt") or "nan") == pytest.approx(150.0)
        assert page.get_attribute("#map", "data-aircraft") == "3"
        _screenshot(page, tmp_path, "viewer-live.png")
    finally:
        assert _stop(proc) == 0


HOSTILE_PAGE = """<!doctype html><title>pending</title><script>
const ws = new WebSocket("ws://127.0.0.1:%(port)s/ws?token=%(token)s");
ws.onopen = () => { ws.send(JSON.stringify({op: "stack", line: "CRE EVIL1 EC35 40.75 -73.98 0 500 40"}));
                    document.title = "opened"; };
ws.onerror = () => { document.title = "refused"; };
</script>"""


def test_a_hostile_page_cannot_drive_a_live_run_but_the_viewers_own_page_can(browser, tmp_path):
    """The browser sends the hostile page's Origin: the upgrade is refused even when it knows the token."""
    import http.server
    import threading

    scn = tmp_path / "three.scn"
    scn.write_text(SCENARIO)
    proc, url = _start(_aamsim("run", str(scn), "--until", "400", "--out", str(tmp_path / "run"), "--quiet",
                               "--view", "--port", "0", "--pace", "5", "--allow-commands"), tmp_path)
    port, token = re.match(r"http://127\.0\.0\.1:(\d+)/\?token=([\w-]+)", url).groups()  # type: ignore[union-attr]
    body = (HOSTILE_PAGE % {"port": port, "token": token}).encode()

    class Hostile(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):
            pass

    hostile = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Hostile)
    threading.Thread(target=hostile.serve_forever, daemon=True).start()
    try:
        page = browser.new_page()
        page.goto(f"http://127.0.0.1:{hostile.server_address[1]}/")
        page.wait_for_function("document.title !== 'pending'", timeout=10_000)
        assert page.title() == "refused"
        own = browser.new_page(viewport={"width": 1100, "height": 750})
        own.goto(url)
        own.wait_for_function("document.getElementById('map').dataset.aircraft === '2'", timeout=20_000)
        assert own.is_visible("#command-form")
        own.fill("#command", "CRE OK1 EC35 40.75 -73.98 0 500 40")
        own.press("#command", "Enter")
        own.wait_for_function("window.viewerState.frame.ids.includes('OK1')", timeout=20_000)
        assert "EVIL1" not in own.evaluate("() => window.viewerState.frame.ids")
        tokenless = browser.new_page()
        tokenless.goto(url.split("?")[0])
        tokenless.wait_for_function("Number(document.getElementById('map').dataset.frames) > 0", timeout=20_000)
        assert not tokenless.is_visible("#command-form")  # without the token the page offers no command box
    finally:
        hostile.shutdown()
        assert _stop(proc) == 130  # Ctrl-C in the middle of the paced run: stopped, outputs complete so far
