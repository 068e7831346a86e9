"""Real-traffic overlay benchmark: 1,000 replayed aircraft beside 100 AAM aircraft (issue 18: > 100x real time).

A recording of ``--aircraft`` aircraft is generated (OpenSky CSV names and SI units, every
aircraft reporting every ``--report-s`` seconds, straight tracks at 60-250 m/s and 300-3,000 m
in a 200 km box, all flying for the whole run), and ``--aam`` EC135s fly 3-waypoint routes in
the middle of it (the traffic of ``bench/bench_sim.py``). The run is what ``aamsim run
--overlay`` does: conflict detection and the NMAC/LoWC events on (the defaults), the replay
updating every second, at dt 0.05 s. Only the stepping is timed (the file is read at REPLAY,
the kernels are compiled by a warm-up run); the same AAM traffic without the overlay is timed
too, for the replay's cost.

    python bench/bench_overlay.py                     # 1,000 + 100 aircraft, 600 s
    python bench/bench_overlay.py --sim-time 300 --stream   # the recording streamed (a window)
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.bench_sim import make_scenario  # noqa: E402

CENTER_LAT, CENTER_LON = 40.7, -74.0  # bench_sim's box


def write_recording(path: Path, aircraft: int, duration_s: float, report_s: float, seed: int = 0) -> int:
    """Straight tracks of ``aircraft`` aircraft reporting every ``report_s`` s, in time order; returns rows."""
    rng = np.random.default_rng(seed)
    half = 100.0 / 111.2
    lat0 = CENTER_LAT + rng.uniform(-half, half, aircraft)
    lon0 = CENTER_LON + rng.uniform(-half, half, aircraft) / np.cos(np.radians(CENTER_LAT))
    speed = rng.uniform(60.0, 250.0, aircraft)
    track = rng.uniform(0.0, 360.0, aircraft)
    alt = rng.uniform(300.0, 3000.0, aircraft)
    north, east = speed * np.cos(np.radians(track)), speed * np.sin(np.radians(track))
    t0 = 1_700_000_000
    rows = 0
    with open(path, "w") as fh:
        fh.write("time,icao24,lat,lon,velocity,heading,vertrate,callsign,onground,baroaltitude\n")
        for t in np.arange(0.0, duration_s + report_s, report_s):
            lat = lat0 + np.degrees(north * t / 6371000.0)
            lon = lon0 + np.degrees(east * t / 6371000.0 / np.cos(np.radians(lat0)))
            for k in range(aircraft):
                fh.write(f"{t0 + t:.0f},{k:06x},{lat[k]:.6f},{lon[k]:.6f},{speed[k]:.2f},{track[k]:.1f},0,"
                         f"B{k:05d},false,{alt[k]:.1f}\n")
            rows += aircraft
    return rows


def timed_run(scenario: str, recording: Path | None, sim_time: float, dt: float, stream: bool) -> tuple[float, int]:
    """Wall time of the stepping, and the most aircraft flying at once."""
    from aamsim import Simulation
    from aamsim.realtraffic import replay as replay_module

    sim = Simulation(seed=0, dt=dt, use_bluesky_navdata=False)
    sim.services.start()
    sim.load_text(scenario)
    if recording is not None:
        feed = replay_module.RecordingFeed(recording, stream_above_bytes=0 if stream else 1 << 40)
        replay_module.Replay(feed, name=str(recording)).attach(sim)
    sim.run_until(0.0)
    most = 0
    wall0 = time.perf_counter()
    for t in np.arange(60.0, sim_time + 1.0, 60.0):
        sim.run_until(float(t))
        most = max(most, sim.view.n)
    return time.perf_counter() - wall0, most


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--aircraft", type=int, default=1000, help="replayed aircraft")
    parser.add_argument("--aam", type=int, default=100, help="AAM aircraft")
    parser.add_argument("--sim-time", type=float, default=600.0, help="simulated seconds")
    parser.add_argument("--report-s", type=float, default=5.0, help="seconds between a recorded aircraft's reports")
    parser.add_argument("--dt", type=float, default=0.05)
    parser.add_argument("--stream", action="store_true", help="stream the recording (a window) instead of reading it")
    args = parser.parse_args()
    scenario = make_scenario(args.aam, seed=0)
    with tempfile.TemporaryDirectory() as tmp:
        recording = Path(tmp) / "recording.csv"
        rows = write_recording(recording, args.aircraft, args.sim_time + 120.0, args.report_s)
        size_mb = recording.stat().st_size / 1e6
        for warm_up in (recording, None):  # compile / load the kernels of both runs before timing
            timed_run(make_scenario(3), warm_up, 5.0, args.dt, args.stream)
        base_wall, base_n = timed_run(scenario, None, args.sim_time, args.dt, False)
        wall, most = timed_run(scenario, recording, args.sim_time, args.dt, args.stream)
    print(f"recording: {args.aircraft} aircraft, {rows:,} reports every {args.report_s:g} s, {size_mb:.1f} MB CSV"
          f"{' (streamed)' if args.stream else ''}")
    print(f"AAM alone:   {base_n} aircraft, {args.sim_time:g} s of sim time in {base_wall:.2f} s wall: "
          f"{args.sim_time / base_wall:,.0f}x real time")
    print(f"with replay: {most} aircraft ({args.aam} AAM + {most - args.aam} replayed), {args.sim_time:g} s in "
          f"{wall:.2f} s wall: {args.sim_time / wall:,.0f}x real time (dt {args.dt:g} s, replay updated every 1 s, "
          f"conflict detection and NMAC/LoWC events on)")
    print(f"REPLAY_SPEEDUP {args.sim_time / wall:.1f}")


if __name__ == "__main__":
    main()
