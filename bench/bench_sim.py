"""Speed benchmark: aircraft-steps per second, aamsim against BlueSky.

N EC35 helicopters fly 3-waypoint routes (LNAV on) in a 60 km box around
40.7N 74.0W at 1400-1600 ft and 100-150 kts, all created with stack text, as
in the BlueSky measurements of the project's BlueSky reference notes
(section 7). Only the stepping loop is timed (600 s of sim time at dt 0.05 s
by default); creation and compilation are not. When bluesky-simulator is
installed the same scenario runs in BlueSky, in a subprocess, in the same
invocation, and the table shows the ratio. Conflict detection is off in both.

The "day" case runs 100 aircraft that are always flying for 24 h of sim time
at dt 0.05 s on one core: every flight lasts 10 minutes (then it is deleted
and a new one takes off), all in stack text, run through ``aamsim run``'s code
path with trajectory logging off (``--log-period 0``).

    python bench/bench_sim.py                          # N = 100, 1000, 10000 + the day
    python bench/bench_sim.py --sizes 100,1000 --no-day --repeat 3
    python bench/bench_sim.py --threads 1,2            # also the multi-threaded kernel
    python bench/bench_sim.py --wind 4 --no-day        # in a wind field of 4 points (both simulators)
    python bench/bench_sim.py --whole-process          # whole processes: aamsim run vs BlueSky, start to exit

Numbers are medians over ``--repeat`` runs (the machine is shared and noisy).

``--whole-process`` times what a user waits for instead of the stepping loop:
N EC35 on random 3-waypoint routes in a 50 km box (dt 0.05 s) written to a
scenario file, then ``python -m aamsim run FILE --until T`` as a subprocess
(after one untimed warm-up run, so that Numba's cache and the byte-code
caches exist), and BlueSky in its own subprocess importing itself, reading the
same file with its scenario reader and stepping to T headless, at N = 100 over
1 h and N = 1,000 over 10 min, plus the trivial run (one aircraft, one
second). The runs of the two simulators alternate; the table shows the median
walls and their ratio, and BlueSky's own split (init, reading, stepping).
``PYTHONDONTWRITEBYTECODE`` is dropped for these subprocesses: an installed
package has its byte code compiled, a development shell that forbids writing
it would add the compile of every module to every start.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

_USER_ENV = dict(os.environ)  # whole processes run in the user's environment, not the settings below
# Idle OpenBLAS worker threads spin on the second core and disturb the timing.
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

CENTER_LAT, CENTER_LON = 40.7, -74.0
BOX_KM = 60.0


def _box_point(rng: np.random.Generator, box_km: float) -> tuple[float, float]:
    half_lat = 0.5 * box_km / 111.2
    half_lon = half_lat / np.cos(np.radians(CENTER_LAT))
    return (CENTER_LAT + rng.uniform(-half_lat, half_lat), CENTER_LON + rng.uniform(-half_lon, half_lon))


def flight_lines(acid: str, rng: np.random.Generator, time_text: str = "00:00:00.00",
                 box_km: float = BOX_KM, waypoints: int = 3) -> list[str]:
    """Stack lines creating one benchmark flight: CRE then ``waypoints`` ADDWPT."""
    lat, lon = _box_point(rng, box_km)
    hdg = rng.uniform(0.0, 360.0)
    alt_ft = rng.uniform(1400.0, 1600.0)
    spd_kt = rng.uniform(100.0, 150.0)
    lines = [f"{time_text}>CRE {acid} EC35 {lat:.6f} {lon:.6f} {hdg:.1f} {alt_ft:.0f} {spd_kt:.0f}"]
    for _ in range(waypoints):
        wlat, wlon = _box_point(rng, box_km)
        lines.append(f"{time_text}>ADDWPT {acid} {wlat:.6f} {wlon:.6f}")
    return lines


def make_scenario(n: int, seed: int = 0, box_km: float = BOX_KM, waypoints: int = 3, wind_points: int = 0) -> str:
    """Scenario text: ``n`` EC35 on random routes, all created at t = 0 (in a wind field of ``wind_points``)."""
    rng = np.random.default_rng(seed)
    lines = [f"# bench_sim: {n} EC35 on {waypoints}-waypoint routes in a {box_km:g} km box, seed {seed}"]
    wind_rng = np.random.default_rng(seed + 1)  # its own draws: the same aircraft with and without wind
    for _ in range(wind_points):
        lat, lon = _box_point(wind_rng, box_km)
        lines.append(f"00:00:00.00>WIND {lat:.6f} {lon:.6f} {wind_rng.uniform(0, 360):.0f} "
                     f"{wind_rng.uniform(5, 30):.0f}")
    for k in range(n):
        lines.extend(flight_lines(f"AC{k:05d}", rng, box_km=box_km, waypoints=waypoints))
    return "\n".join(lines) + "\n"


def _hms(t: float) -> str:
    h, rem = divmod(t, 3600.0)
    m, s = divmod(rem, 60.0)
    return f"{int(h):02d}:{int(m):02d}:{s:05.2f}"


def make_day_scenario(n: int = 100, duration_s: float = 86400.0, flight_s: float = 600.0, seed: int = 0) -> str:
    """Scenario text keeping ``n`` aircraft in the air for ``duration_s``.

    Slot k's first flight is cut short to ``flight_s * (k + 1) / n`` so that
    replacements spread evenly; after that every flight lasts ``flight_s``:
    at its end a DEL and a CRE + ADDWPTs of the next flight share one time.
    """
    rng = np.random.default_rng(seed)
    lines = [f"# bench_sim day: {n} aircraft always flying for {duration_s:g} s, flights of {flight_s:g} s"]
    for k in range(n):
        t = 0.0
        number = 0
        acid = f"S{k:03d}F{number:04d}"
        lines.extend(flight_lines(acid, rng, _hms(t)))
        t = flight_s * (k + 1) / n
        while t < duration_s:
            number += 1
            new = f"S{k:03d}F{number:04d}"
            lines.append(f"{_hms(t)}>DEL {acid}")
            lines.extend(flight_lines(new, rng, _hms(t)))
            acid = new
            t += flight_s
    return "\n".join(lines) + "\n"


@dataclass
class Timing:
    wall_s: float
    aircraft_steps: int
    sim_s: float

    @property
    def rate(self) -> float:
        return self.aircraft_steps / self.wall_s

    @property
    def realtime(self) -> float:
        return self.sim_s / self.wall_s


def _warm_up(threads: tuple[int, ...] = (1,)) -> None:
    """Load (or compile) the kernels and start the threads before anything is timed."""
    from aamsim import Simulation
    from aamsim.simulation import PARALLEL_MIN_AIRCRAFT

    for nthreads in threads:
        sim = Simulation(seed=0, use_bluesky_navdata=False, threads=nthreads)
        sim.load_text(make_scenario(PARALLEL_MIN_AIRCRAFT if nthreads > 1 else 3))
        sim.run_until(2.0)


def time_aamsim(text: str, sim_time: float, dt: float = 0.05, threads: int = 1) -> Timing:
    """Wall time of aamsim's stepping loop over ``sim_time`` seconds."""
    from aamsim import Simulation

    sim = Simulation(seed=0, dt=dt, use_bluesky_navdata=False, threads=threads)
    sim.load_text(text)
    sim.run_until(0.0)  # runs the creation commands due at t = 0, no step
    steps0 = sim.aircraft_steps
    t0 = time.perf_counter()
    sim.run_until(sim_time)
    wall = time.perf_counter() - t0
    errors = sim.reporter.errors()
    if errors:
        raise RuntimeError(f"aamsim reported errors: {errors[:3]}")
    return Timing(wall, sim.aircraft_steps - steps0, sim.simt)


_BLUESKY_WORKER = r"""
import contextlib, io, json, sys, time
with contextlib.redirect_stdout(io.StringIO()):
    import bluesky as bs
    bs.init(mode='sim', detached=True, workdir=sys.argv[1])
    bs.stack.stack('DT %(dt)r')
    bs.sim.step()
lines = [l.split('>', 1)[1] for l in open(sys.argv[2]) if '>' in l and not l.startswith('#')]
bs.stack.set_scendata([0.0] * len(lines), lines)
bs.sim.step()  # creation (and the first step): not timed
steps = 0
sim_time = %(sim_time)r
t0 = time.perf_counter()
while bs.sim.simt < sim_time - 1e-9:
    steps += bs.traf.ntraf
    bs.sim.step()
wall = time.perf_counter() - t0
print(json.dumps({"wall_s": wall, "aircraft_steps": steps, "sim_s": bs.sim.simt}))
"""


def bluesky_available() -> bool:
    from importlib.util import find_spec

    return find_spec("bluesky") is not None


def time_bluesky(text: str, sim_time: float, dt: float = 0.05) -> Timing:
    """Wall time of BlueSky's stepping loop on the same scenario (subprocess, one core)."""
    with tempfile.TemporaryDirectory(prefix="bench-bluesky-") as tmp:
        scn = Path(tmp) / "bench.scn"
        scn.write_text(text)
        code = _BLUESKY_WORKER % {"dt": dt, "sim_time": sim_time}
        env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
        proc = subprocess.run([sys.executable, "-c", code, tmp, str(scn)], capture_output=True, text=True, env=env,
                              check=False)
        if proc.returncode != 0:
            raise RuntimeError(f"BlueSky run failed:\n{proc.stderr[-3000:]}")
        out = json.loads(proc.stdout.strip().splitlines()[-1])
    return Timing(out["wall_s"], out["aircraft_steps"], out["sim_s"])


WHOLE_BOX_KM = 50.0
WHOLE_CASES = ((100, 3600.0), (1000, 600.0))
TRIVIAL_SCENARIO = "# bench_sim: one aircraft\n00:00:00.00>CRE AC00000 EC35 40.700000 -74.000000 90.0 1500 120\n"

_BLUESKY_WHOLE = r"""
import contextlib, io, json, sys, time
t0 = time.perf_counter()
with contextlib.redirect_stdout(io.StringIO()):
    import bluesky as bs
    bs.init(mode='sim', detached=True, workdir=sys.argv[1])
    from bluesky.stack import simstack
    bs.stack.stack('DT %(dt)r')
    bs.sim.step()
    t1 = time.perf_counter()
    bs.sim.reset()
    lines = simstack.readscn(sys.argv[2])
    bs.stack.set_scendata([t for t, _ in lines], [c for _, c in lines])
    t2 = time.perf_counter()
    ntraf = 0
    while bs.sim.simt < %(sim_time)r - 1e-9:
        bs.sim.step()
        ntraf = max(ntraf, bs.traf.ntraf)
t3 = time.perf_counter()
print(json.dumps({"init_s": t1 - t0, "read_s": t2 - t1, "step_s": t3 - t2, "ntraf": ntraf, "simt": bs.sim.simt}))
"""


def _whole_env(root: Path = ROOT) -> dict[str, str]:
    env = dict(_USER_ENV)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), env.get("PYTHONPATH", "")) if p)
    return env


def whole_aamsim(scn: Path, sim_time: float, dt: float, out_dir: Path, root: Path = ROOT) -> tuple[float, dict]:
    """Wall [s] of ``aamsim run`` (the source tree ``root``) as a whole process, and the run's summary."""
    cmd = [sys.executable, "-m", "aamsim", "run", str(scn), "--until", f"{sim_time:g}", "--dt", f"{dt:g}",
           "--out", str(out_dir), "--quiet"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=_whole_env(root), cwd=root, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"aamsim run failed:\n{proc.stderr[-3000:]}")
    return wall, json.loads((out_dir / "summary.json").read_text())


def whole_bluesky(scn: Path, sim_time: float, dt: float, workdir: Path) -> tuple[float, dict]:
    """Wall [s] of a BlueSky process that imports, initialises, reads ``scn`` and steps to ``sim_time``."""
    code = _BLUESKY_WHOLE % {"dt": dt, "sim_time": sim_time}
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", code, str(workdir), str(scn)], capture_output=True, text=True,
                          env=_whole_env(), check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"BlueSky run failed:\n{proc.stderr[-3000:]}")
    return wall, json.loads(proc.stdout.strip().splitlines()[-1])


def whole_process(repeat: int, dt: float, use_bluesky: bool, cases: tuple[tuple[int, float], ...],
                  before: Path | None = None) -> None:
    """Print whole-process walls of aamsim run and BlueSky on the same scenario files.

    ``before``: another aamsim source tree (an older commit) run alongside, for before/after ratios.
    """
    print(f"whole processes: EC35 on 3-waypoint routes, {WHOLE_BOX_KM:g} km box, dt {dt:g} s, median of {repeat}, "
          f"cpu count {os.cpu_count()}, load {os.getloadavg()[0]:.2f}")
    header = (f"{'case':>16} {'aamsim s':>9} {'BlueSky s':>10} {'(init':>7} {'read':>6} {'step)':>7} {'ratio':>7}"
              + (f" {'before s':>9} {'ratio':>7} {'speed-up':>8}" if before else ""))
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory(prefix="bench-whole-") as tmp_name:
        tmp = Path(tmp_name)
        all_cases = [(1, 1.0), *cases]
        roots = [ROOT] + ([before] if before else [])
        for k, (n, sim_time) in enumerate(all_cases):
            scn = tmp / f"whole_{n}.scn"
            scn.write_text(TRIVIAL_SCENARIO if k == 0 else make_scenario(n, box_km=WHOLE_BOX_KM))
            if k == 0:
                for j, root in enumerate(roots):  # Numba's cache, byte code
                    whole_aamsim(scn, sim_time, dt, tmp / f"warm-up-{j}", root)
            walls: dict[Path, list[float]] = {root: [] for root in roots}
            theirs: list[tuple[float, dict]] = []
            for r in range(repeat):
                if use_bluesky:
                    theirs.append(whole_bluesky(scn, sim_time, dt, tmp))
                for j, root in enumerate(roots):
                    wall, summary = whole_aamsim(scn, sim_time, dt, tmp / f"run-{n}-{r}-{j}", root)
                    if summary["flights_created"] != n or summary["errors"]:
                        raise RuntimeError(f"aamsim: {summary['flights_created']} flights, {summary['errors']} errors")
                    walls[root].append(wall)
            label = f"N={n:,} {sim_time:g} s"
            ours_s = statistics.median(walls[ROOT])
            line = f"{label:>16} {ours_s:9.2f}"
            bs_s = None
            if theirs:
                bs_s = statistics.median(w for w, _ in theirs)
                split = min(theirs, key=lambda t: abs(t[0] - bs_s))[1]
                if split["ntraf"] != n:
                    raise RuntimeError(f"BlueSky created {split['ntraf']} aircraft, not {n}")
                line += (f" {bs_s:10.2f} {split['init_s']:7.2f} {split['read_s']:6.2f} {split['step_s']:7.2f} "
                         f"{bs_s / ours_s:7.1f}")
            else:
                line += f" {'-':>10} {'':>7} {'':>6} {'':>7} {'-':>7}"
            if before:
                old_s = statistics.median(walls[before])
                line += f" {old_s:9.2f} {bs_s / old_s if bs_s else math.nan:7.1f} {old_s / ours_s:8.2f}"
            print(line, flush=True)
    print(f"load after: {os.getloadavg()[0]:.2f}")


def _median(timings: list[Timing]) -> Timing:
    walls = [t.wall_s for t in timings]
    mid = statistics.median(walls)
    best = min(timings, key=lambda t: abs(t.wall_s - mid))
    return Timing(mid, best.aircraft_steps, best.sim_s)


def run_day(n: int = 100, duration_s: float = 86400.0, dt: float = 0.05) -> tuple[float, float, dict]:
    """The day case through ``aamsim run``'s code path; returns (total wall, stepping wall, summary)."""
    from aamsim.runner import RunConfig, run_scenario

    with tempfile.TemporaryDirectory(prefix="bench-day-") as tmp:
        scn = Path(tmp) / "day.scn"
        scn.write_text(make_day_scenario(n, duration_s))
        t0 = time.perf_counter()
        result = run_scenario(RunConfig(scn, out_dir=Path(tmp) / "run", until_s=duration_s, dt_s=dt,
                                        seed=0, log_period_s=0.0))
        total = time.perf_counter() - t0
    return total, result.wall_s, result.summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="100,1000,10000", help="comma-separated numbers of aircraft")
    parser.add_argument("--sim-time", type=float, default=600.0, help="simulated seconds per run")
    parser.add_argument("--dt", type=float, default=0.05, help="time step [s]")
    parser.add_argument("--repeat", type=int, default=3, help="runs per case (the median is shown)")
    parser.add_argument("--threads", default="1", help="comma-separated Numba thread counts for aamsim")
    parser.add_argument("--bluesky", dest="bluesky", action=argparse.BooleanOptionalAction, default=None,
                        help="also run BlueSky (default: when it is installed)")
    parser.add_argument("--bluesky-large-sim-time", type=float, default=60.0,
                        help="BlueSky's sim time for N >= 10000 (it is slow there; rates are compared)")
    parser.add_argument("--day", action=argparse.BooleanOptionalAction, default=True,
                        help="also run the day case (100 aircraft, 24 h)")
    parser.add_argument("--wind", type=int, default=0, metavar="POINTS",
                        help="wind points (no altitude profile) in the box, in both simulators (default: no wind)")
    parser.add_argument("--day-duration", type=float, default=86400.0, help="sim time of the day case [s]")
    parser.add_argument("--whole-process", action="store_true",
                        help="time whole processes (aamsim run vs BlueSky) instead of the stepping loop")
    parser.add_argument("--before", type=Path, default=None, metavar="DIR",
                        help="with --whole-process: also run aamsim from this source tree (e.g. an older commit)")
    parser.add_argument("--cases", default=",".join(f"{n}:{t:g}" for n, t in WHOLE_CASES),
                        help="whole-process cases N:SIM_SECONDS, comma-separated (the trivial run is always added)")
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s]
    threads = [int(s) for s in args.threads.split(",") if s]
    use_bluesky = bluesky_available() if args.bluesky is None else args.bluesky
    if use_bluesky and not bluesky_available():
        parser.error("--bluesky: bluesky-simulator is not installed")
    if args.whole_process:
        cases = tuple((int(c.split(":")[0]), float(c.split(":")[1])) for c in args.cases.split(",") if c)
        whole_process(args.repeat, args.dt, use_bluesky, cases, args.before)
        return 0

    import numba

    _warm_up(tuple(threads))
    print(f"aamsim bench: EC35 on 3-waypoint routes, {BOX_KM:g} km box, dt {args.dt:g} s, "
          f"{args.sim_time:g} s sim time, {args.wind} wind points, median of {args.repeat}, cpu count {os.cpu_count()}, "
          f"numba {numba.__version__}")
    header = f"{'N':>6} {'threads':>7} {'aamsim ac-steps/s':>18} {'x realtime':>10} " \
             f"{'BlueSky ac-steps/s':>19} {'BS sim s':>8} {'ratio':>7}"
    print(header)
    print("-" * len(header))
    for n in sizes:
        text = make_scenario(n, wind_points=args.wind)
        bs_sim = args.sim_time if n < 10000 else min(args.sim_time, args.bluesky_large_sim_time)
        # Runs alternate between the simulators, so that a change in the
        # machine's load hits both alike.
        bs_runs: list[Timing] = []
        our_runs: dict[int, list[Timing]] = {k: [] for k in threads}
        for _ in range(args.repeat):
            if use_bluesky:
                bs_runs.append(time_bluesky(text, bs_sim, args.dt))
            for nthreads in threads:
                our_runs[nthreads].append(time_aamsim(text, args.sim_time, args.dt, nthreads))
        bs_timing = _median(bs_runs) if bs_runs else None
        for nthreads in threads:
            ours = _median(our_runs[nthreads])
            bs_rate = f"{bs_timing.rate / 1e6:16.3f} M" if bs_timing else f"{'-':>18}"
            bs_sim_txt = f"{bs_timing.sim_s:8.0f}" if bs_timing else f"{'-':>8}"
            ratio = f"{ours.rate / bs_timing.rate:7.1f}" if bs_timing else f"{'-':>7}"
            print(f"{n:>6} {nthreads:>7} {ours.rate / 1e6:16.3f} M {ours.realtime:10.0f} {bs_rate} {bs_sim_txt} {ratio}",
                  flush=True)
    if args.day:
        total, stepping, summary = run_day(100, args.day_duration, args.dt)
        print(f"day: 100 aircraft always flying, {args.day_duration:g} s at dt {args.dt:g} s, one thread: "
              f"{total:.1f} s wall in all, {stepping:.1f} s simulating "
              f"({summary['aircraft_steps'] / stepping / 1e6:.2f} M ac-steps/s, "
              f"x{summary['speedup']:.0f} realtime, {summary['flights_created']} flights)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
