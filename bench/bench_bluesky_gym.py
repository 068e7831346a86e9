"""Steps per second of bluesky-gym's environments on BlueSky and on aamsim, side by side.

Each environment runs in fresh processes (BlueSky keeps process-wide state):
one on bluesky-simulator, one on aamsim (``aamsim.compat.bluesky.install()``),
the same fixed actions and seed, through ``tests/bluesky_gym_episode.py``.
The first ``--warmup`` steps are not timed (aamsim loads its compiled kernel
there); the timed steps include the resets of episodes that end, as training
does. Start-up (imports, ``gym.make``, first reset) is reported apart. With
``--repeat`` the rounds alternate which side runs first and the best round of
each side counts, which damps the noise of a shared machine::

    python bench/bench_bluesky_gym.py                       # all seven, 100 steps
    python bench/bench_bluesky_gym.py --envs MergeEnv-v0 --steps 200 --repeat 3 --markdown

Needs bluesky-gym (``pip install 'aamsim[bluesky-gym]'``) and bluesky-simulator.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RUNNER = ROOT / "tests" / "bluesky_gym_episode.py"
ENV_IDS = ("DescentEnv-v0", "PlanWaypointEnv-v0", "HorizontalCREnv-v0", "VerticalCREnv-v0", "SectorCREnv-v0",
           "StaticObstacleEnv-v0", "MergeEnv-v0")


def measure(env_id: str, backend: str, steps: int, warmup: int, seed: int) -> tuple[float, float]:
    """(timed steps per second, start-up seconds) of one run in a fresh process."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.npz"
        proc = subprocess.run([sys.executable, str(RUNNER), env_id, backend, str(steps + warmup), str(seed), str(out),
                               str(warmup)], capture_output=True, text=True, env=env, check=False)
        if proc.returncode != 0:
            raise RuntimeError(f"{env_id} on {backend} failed:\n{proc.stderr[-3000:]}")
        data = np.load(out)
        return float(data["timed_steps"]) / float(data["seconds"]), float(data["startup_seconds"])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", nargs="+", default=list(ENV_IDS))
    parser.add_argument("--steps", type=int, default=100, help="timed environment steps per run")
    parser.add_argument("--warmup", type=int, default=5, help="untimed steps first")
    parser.add_argument("--repeat", type=int, default=1, help="rounds per side (the best counts)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    args = parser.parse_args(argv)

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{os.cpu_count()} CPUs, load average {load:.1f}; {args.steps} timed steps after {args.warmup}, "
          f"best of {args.repeat}", flush=True)
    rows = []
    for env_id in args.envs:
        best = {"bluesky": (0.0, 0.0), "aamsim": (0.0, 0.0)}
        for k in range(args.repeat):
            for backend in (("bluesky", "aamsim") if k % 2 == 0 else ("aamsim", "bluesky")):
                sps, startup = measure(env_id, backend, args.steps, args.warmup, args.seed)
                if sps > best[backend][0]:
                    best[backend] = (sps, startup)
        (bs_sps, bs_start), (aam_sps, aam_start) = best["bluesky"], best["aamsim"]
        rows.append((env_id, bs_sps, aam_sps, aam_sps / bs_sps, bs_start, aam_start))
        print(f"{env_id:22s} BlueSky {bs_sps:8.1f} steps/s   aamsim {aam_sps:8.1f} steps/s   "
              f"ratio {aam_sps / bs_sps:5.1f}x   (start-up {bs_start:.1f} s / {aam_start:.1f} s)", flush=True)
    if args.markdown:
        print("\n| environment | BlueSky 1.1.1 steps/s | aamsim steps/s | ratio | start-up BlueSky / aamsim |")
        print("|---|---|---|---|---|")
        for env_id, bs_sps, aam_sps, ratio, bs_start, aam_start in rows:
            print(f"| {env_id} | {bs_sps:.1f} | {aam_sps:.1f} | {ratio:.1f}x | {bs_start:.1f} s / {aam_start:.1f} s |")


if __name__ == "__main__":
    main()
