"""Where a vector environment's step goes: a workload to sample, and the sampled stacks sorted into parts of a step.

Run the workload under a sampling profiler (py-spy: ``pip install py-spy``), then sort its samples:

    py-spy record -r 500 -f raw -o v1.raw -- python bench/step_profile.py --kind v1 --steps 600
    python bench/step_profile.py --categorize v1.raw

``--kind v1``/``v0``: ``gymnasium.make_vec("aamgym/CorridorSA-v1", num_envs=N)`` (the native
``AamVectorEnv``) with random actions; ``--kind multi``: ``AamParallelVectorEnv`` of N episodes,
random actions for every agent, read as arrays (what the rollout workers do). Only the timed
steps count (samples under ``_steps``): imports, Numba's cache and the first reset are left out.
Each sample goes to the innermost frame that names a part of the step (the kernel call, the
conflict check, a use-case method, ...); the rest is the Python around them.
"""

from __future__ import annotations

import argparse
import collections
import os
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

# (part of the step, text of a frame); a sample goes to the first part whose text its innermost
# matching frame holds (frames are searched from the innermost out).
PARTS = (
    ("kernel (advance_ranges, all worlds in one call)", "pool.py:124)"),
    ("kernel (a world's own batch)", "simulation.py:398)"),
    ("conflict service: the 1 s check", "ConflictService.check"),
    ("scenario commands (CRE, ADDWPT, DEL, ...)", "_run_due_commands"),
    ("waypoint passing, conditions fired", "_after_kernel"),
    ("use case: observe", ".observe ("),
    ("use case: feedback (rewards, NMAC/LoWC of the interval)", ".feedback ("),
    ("use case: apply actions (advisory counts)", "apply_actions"),
    ("other periodic hooks (resolution services)", "call_due"),
    ("world set: joint kernel arguments (conditions, ranges)", "TrafficPool.advance"),
    ("world set: batches, boundaries", "WorldSet"),
    ("episode engine (rlbridge/core.py)", "rlbridge/core.py"),
    ("vector environment (rlbridge/vector)", "rlbridge/vector"),
)


def categorize(raw: Path) -> None:
    counts: collections.Counter[str] = collections.Counter()
    for line in raw.read_text().splitlines():
        stack, _, n = line.rpartition(" ")
        frames = stack.split(";")
        if not any(f.startswith("_steps ") for f in frames):
            continue
        part = "other"
        for frame in reversed(frames):
            part = next((name for name, text in PARTS if text in frame), "")
            if part:
                break
        counts[part or "other"] += int(n)
    total = sum(counts.values())
    print(f"{raw}: {total:,} samples in the timed steps")
    for name, k in counts.most_common():
        print(f"  {name:58} {k:7,d} {100 * k / total:5.1f} %")


def _steps(step, steps: int) -> None:  # the frame that marks the timed part
    for t in range(steps):
        step(t)


def workload(kind: str, n: int, steps: int, scenario: str, interval: float, seed: int) -> None:
    import gymnasium
    import numpy as np

    import rlbridge  # noqa: F401  (registers the aamgym ids)
    from rlbridge.vector import AamParallelVectorEnv

    kwargs = {"scenario": scenario, "decision_interval_s": interval}
    rng = np.random.default_rng(seed)
    if kind in ("v0", "v1"):
        env = gymnasium.make_vec(f"aamgym/CorridorSA-{kind}", num_envs=n, vectorization_mode="vector_entry_point",
                                 **kwargs)
        env.reset(seed=seed)
        actions = rng.integers(0, 3, (steps, n))

        def step(t: int) -> None:
            env.step(actions[t])
    else:
        vec = AamParallelVectorEnv(n, **kwargs)
        vec.reset(seed=seed)

        def step(t: int) -> None:
            vec.step_results([dict(zip(a, rng.integers(0, 3, len(a)).tolist())) for a in vec.agents])

    c0, t0 = time.process_time(), time.perf_counter()
    _steps(step, steps)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    print(f"{kind}, N = {n}, {steps} steps: {cpu:.2f} CPU-s, {wall:.2f} s wall; load average "
          f"{os.getloadavg()[0]:.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--categorize", type=Path, help="a py-spy raw file (-f raw) of this workload: print its parts")
    ap.add_argument("--kind", choices=("v1", "v0", "multi"), default="v1")
    ap.add_argument("--num-envs", type=int, default=16)
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--scenario", default="nyc_train_100.scn")
    ap.add_argument("--interval", type=float, default=1.0, help="decision interval [s]")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    if args.categorize is not None:
        categorize(args.categorize)
    else:
        workload(args.kind, args.num_envs, args.steps, args.scenario, args.interval, args.seed)


if __name__ == "__main__":
    main()
