"""Cost of conflict detection and loss-of-separation tracking.

Runs N EC135s on random routes in a 60 km box around New York (as
bench_sim.py) with the conflict service off and on, and prints
aircraft-steps per second, the relative cost of CD and the speed-up over real
time. "CD on" means: loss-of-separation tracking for the paper's NMAC (150 m)
and LoWC (450 m) volumes every second with closest-point-of-approach between
checks, closest-intruder distances, and BlueSky STATEBASED conflict detection
(ZONER 450 m, ZONEDH and DTLOOK as given).

    python bench/bench_conflicts.py --sizes 100 1000 10000 --sim-time 300
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from aamsim import Simulation


def box_scenario(n: int, seed: int = 0, half_box_m: float = 30000.0) -> str:
    """N EC135s at 1400-1600 ft, 100-150 kt, three random waypoints each, in a 60 km box."""
    rng = np.random.default_rng(seed)
    dlat = half_box_m / 111195.0
    dlon = dlat / np.cos(np.radians(40.7))
    lines = []
    for k in range(n):
        lat, lon = 40.7 + rng.uniform(-dlat, dlat), -74.0 + rng.uniform(-dlon, dlon)
        lines.append(f"00:00:00.00>CRE A{k} EC35 {lat:.6f} {lon:.6f} {rng.uniform(0, 360):.1f} "
                     f"{rng.uniform(1400, 1600):.0f} {rng.uniform(100, 150):.0f}")
        for _ in range(3):
            lines.append(f"00:00:00.00>ADDWPT A{k} {40.7 + rng.uniform(-dlat, dlat):.6f} "
                         f"{-74.0 + rng.uniform(-dlon, dlon):.6f}")
    return "\n".join(lines)


def run_once(n: int, sim_time: float, cd: bool, dtlook: float, zonedh_ft: float,
             asas: bool = True) -> tuple[float, int, int]:
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    if cd:
        sim.services.start()
        if asas:
            sim.stack(f"ASAS ON; ZONER 0.243; ZONEDH {zonedh_ft}; DTLOOK {dtlook}")
    sim.load_text(box_scenario(n))
    sim.run_until(0.0)
    t0 = time.perf_counter()
    sim.run_until(sim_time)
    wall = time.perf_counter() - t0
    service = sim.services.conflicts
    events = (service.count("nmac"), service.count("lowc")) if sim.services.started else (0, 0)
    return wall, *events


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 10000])
    ap.add_argument("--sim-time", type=float, default=300.0, help="simulated seconds per run")
    ap.add_argument("--repeat", type=int, default=3, help="runs per case (median reported)")
    ap.add_argument("--dtlook", type=float, default=60.0, help="CD look-ahead [s] (BlueSky default 300)")
    ap.add_argument("--zonedh", type=float, default=1000.0, help="CD vertical half-height [ft]")
    ap.add_argument("--no-asas", action="store_true",
                    help="only loss-of-separation events and metrics (ASAS state-based CD off, the run default)")
    args = ap.parse_args()
    steps = args.sim_time / 0.05
    # Load the compiled code once (Numba's cache) so that the timed runs measure the simulation only.
    run_once(20, 2.0, True, args.dtlook, args.zonedh, not args.no_asas)
    what = ("LoS events + metrics only (ASAS off)" if args.no_asas else
            f"ASAS STATEBASED ZONER 450 m, ZONEDH {args.zonedh:g} ft, DTLOOK {args.dtlook:g} s + LoS events + metrics")
    print(f"dt 0.05 s, {args.sim_time:.0f} s simulated, checks every 1 s: {what}; median of {args.repeat}")
    print(f"{'N':>6} {'CD off ac-steps/s':>18} {'CD on ac-steps/s':>17} {'CD cost':>8} {'x real time (on)':>17} "
          f"{'NMAC':>6} {'LoWC':>6}")
    for n in args.sizes:
        reps = max(1, args.repeat if n <= 1000 else 1)
        off = statistics.median(run_once(n, args.sim_time, False, args.dtlook, args.zonedh)[0] for _ in range(reps))
        runs = [run_once(n, args.sim_time, True, args.dtlook, args.zonedh, not args.no_asas) for _ in range(reps)]
        on = statistics.median(r[0] for r in runs)
        print(f"{n:>6} {n * steps / off:>18,.0f} {n * steps / on:>17,.0f} {on / off - 1:>8.1%} "
              f"{args.sim_time / on:>17.1f} {runs[0][1]:>6} {runs[0][2]:>6}")


if __name__ == "__main__":
    main()
