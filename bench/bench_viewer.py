"""The web viewer on a day of traffic: frames per second in a real browser and the server's CPU.

Runs ``aamsim run scn/nyc_day.scn`` (4,051 flights, unless ``--run-dir`` names
an existing run), serves it with ``aamsim view`` in its own process, loads the
page in headless Chromium (Playwright against a system Chromium) and plays the
busiest hour at several speeds. For each speed it prints:

* frames drawn per second by the page (``requestAnimationFrame``; the canvas
  is redrawn every animation frame) and the mean time one draw takes;
* frames received per second over the WebSocket (the server sends ten);
* the server process's CPU time per wall second (``/proc/<pid>/stat``).

Headless Chromium draws with the CPU here (no GPU), so the browser figures
are a lower bound for a desktop browser.

    python bench/bench_viewer.py                      # runs nyc_day first (about 15 s)
    python bench/bench_viewer.py --run-dir runs/nyc_day-... --seconds 10 --speeds 60 600 6000
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process [s] (Linux)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--run-dir", type=Path, default=None, help="an existing run directory (default: run nyc_day)")
    ap.add_argument("--seconds", type=float, default=10.0, help="wall seconds measured per speed")
    ap.add_argument("--speeds", type=float, nargs="+", default=[60.0, 600.0, 6000.0])
    ap.add_argument("--size", default="1400x900", help="browser viewport WIDTHxHEIGHT")
    ap.add_argument("--stress", type=int, default=0, metavar="N",
                    help="instead of nyc_day: N aircraft at once on random headings in a 50 km box for 10 min")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright

    chromium = next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)
    if chromium is None:
        sys.exit("no Chromium on PATH (Debian: apt-get install chromium)")
    tmp = Path(tempfile.mkdtemp(prefix="bench_viewer_"))
    run_dir = args.run_dir
    if run_dir is None and args.stress:
        import numpy as np

        rng = np.random.default_rng(1)
        lat = 40.7 + rng.uniform(-0.225, 0.225, args.stress)
        lon = -74.0 + rng.uniform(-0.3, 0.3, args.stress)
        hdg = rng.uniform(0, 360, args.stress)
        alt = rng.choice([500, 1000, 1500, 2000], args.stress)
        scn = tmp / f"stress_{args.stress}.scn"
        scn.write_text("".join(f"00:00:00.00>CRE S{k:05d} EC35 {a:.5f} {o:.5f} {h:.1f} {z} 100\n"
                               for k, (a, o, h, z) in enumerate(zip(lat, lon, hdg, alt))))
        run_dir = tmp / scn.stem
        subprocess.run([sys.executable, "-m", "aamsim", "run", str(scn), "--until", "600", "--out", str(run_dir),
                        "--quiet"], check=True)
        print(f"{args.stress} aircraft for 10 min -> {run_dir}")
    if run_dir is None:
        run_dir = tmp / "nyc_day"
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "aamsim", "run", "scn/nyc_day.scn", "--out", str(run_dir), "--quiet"],
                       check=True)
        print(f"nyc_day simulated in {time.perf_counter() - t0:.1f} s -> {run_dir}")
    size_mb = (run_dir / "trajectories.csv").stat().st_size / 1e6
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "aamsim", "view", str(run_dir), "--port", "0"],
                            stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    url = None
    for line in proc.stderr:
        m = re.search(r"viewer: (http://\S+)", line)
        if m:
            url = m.group(1)
            break
    if url is None:
        sys.exit("aamsim view printed no URL")
    print(f"server up in {time.perf_counter() - t0:.1f} s (indexing {size_mb:.0f} MB of trajectories)")
    width, height = (int(x) for x in args.size.split("x"))
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": width, "height": height})
            page.goto(url)
            page.wait_for_function("window.viewerStats && window.viewerStats.received > 2", timeout=30_000)
            meta = page.evaluate("async () => (await (await fetch('/api/meta')).json())")
            t_peak, n_peak = meta["busiest"]["t"], meta["busiest"]["aircraft"]
            print(f"busiest sample: {n_peak} aircraft at t = {t_peak} s; viewport {width}x{height}")
            print(f"{'speed':>8} {'browser fps':>12} {'draw ms':>8} {'frames rx/s':>12} {'aircraft':>9} "
                  f"{'server CPU %':>13}")
            for speed in args.speeds:
                page.evaluate(f"""() => {{ const s = window.viewerState; s.ws.send(JSON.stringify({{op: 'seek',
                    t: {max(t_peak - 600, meta['t_start'])}}})); s.ws.send(JSON.stringify({{op: 'speed', x: {speed}}}));
                    s.ws.send(JSON.stringify({{op: 'play'}})); }}""")
                page.wait_for_timeout(1000)
                before = page.evaluate("() => ({drawn: window.viewerStats.drawn, rx: window.viewerStats.received,"
                                       " t: performance.now()})")
                cpu0, wall0 = cpu_seconds(proc.pid), time.perf_counter()
                draw_ms, counts = [], []
                end = wall0 + args.seconds
                while time.perf_counter() < end:
                    page.wait_for_timeout(250)
                    s = page.evaluate("() => [window.viewerStats.drawMs, "
                                      "Number(document.getElementById('map').dataset.aircraft)]")
                    draw_ms.append(s[0])
                    counts.append(s[1])
                after = page.evaluate("() => ({drawn: window.viewerStats.drawn, rx: window.viewerStats.received,"
                                      " t: performance.now()})")
                cpu = cpu_seconds(proc.pid) - cpu0
                wall = time.perf_counter() - wall0
                dt = (after["t"] - before["t"]) / 1000
                print(f"{speed:>7g}x {(after['drawn'] - before['drawn']) / dt:>12.1f} "
                      f"{sum(draw_ms) / len(draw_ms):>8.2f} {(after['rx'] - before['rx']) / dt:>12.1f} "
                      f"{max(counts):>9d} {100 * cpu / wall:>12.1f}%")
            browser.close()
    finally:
        proc.terminate()
        proc.wait(20)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
