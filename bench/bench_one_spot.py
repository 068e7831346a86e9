"""Aircraft piled on one spot: the time and memory of the next episode step, old code against new.

A client of ``aamsim serve`` can ``stack`` thousands of ``CRE`` at one position; every pair is then in
conflict and inside both separation volumes. This runs that in a ``corridor_sa`` episode of
``nyc_train_100.scn`` (what a server session holds), in a fresh process per case so that peak
resident sizes are comparable, once per checkout given, alternating:

    python bench/bench_one_spot.py --sizes 1000 3000 --checkout OLD_TREE --checkout .

prints, per checkout and size, the ``stack`` time, the ``step`` time and the process's peak RSS.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import json, resource, sys, time
from rlbridge.core import EpisodeCore
n = int(sys.argv[1])
core = EpisodeCore("nyc_train_100.scn", "corridor_sa")
core.reset(0)
core.step({})  # warm: compiled kernels loaded before the clock starts
text = "; ".join(f"CRE Z{k} EC35 40.7 -74.0 0 500 0" for k in range(n))
t0 = time.perf_counter()
core.stack(text)
t1 = time.perf_counter()
core.step({})
t2 = time.perf_counter()
print(json.dumps({"stack_s": t1 - t0, "step_s": t2 - t1,
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def run(checkout: Path, n: int, timeout_s: float) -> dict[str, float] | str:
    env = dict(os.environ, PYTHONPATH=str(checkout))
    try:
        proc = subprocess.run([sys.executable, "-c", CHILD, str(n)], env=env, capture_output=True, text=True,
                              timeout=timeout_s, check=False, cwd=checkout)
    except subprocess.TimeoutExpired:
        return f"over {timeout_s:g} s"
    if proc.returncode != 0:
        return f"failed: {proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else proc.returncode}"
    return json.loads(proc.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 3000])
    ap.add_argument("--checkout", type=Path, action="append", required=True,
                    help="a source tree to measure (repeat: old, then new)")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=1200.0, help="seconds a case may take")
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(f"{'checkout':40} {'N':>6} {'stack s':>8} {'step s':>8} {'peak RSS MB':>12}")
    for _ in range(args.rounds):
        for n in args.sizes:
            for checkout in args.checkout:
                r = run(checkout.resolve(), n, args.timeout)
                if isinstance(r, str):
                    print(f"{checkout!s:40} {n:>6} {r}")
                else:
                    print(f"{checkout!s:40} {n:>6} {r['stack_s']:>8.2f} {r['step_s']:>8.2f} "
                          f"{r['peak_rss_mb']:>12.0f}")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
