"""The native vector environments against Gymnasium's ``SyncVectorEnv`` and separate PettingZoo envs, side by side.

Single agent: ``gymnasium.make_vec(ID, num_envs=N)`` (the native ``AamVectorEnv``) and
``gymnasium.make_vec(ID, num_envs=N, vectorization_mode="sync")`` (``SyncVectorEnv`` of N
separate envs) on the same seeds and the same random actions, each for ``--steps`` vector
steps after the first reset (autoresets included, as they come: a ``-v1`` reset flies the
traffic until its drawn ego exists). Multi agent: ``AamParallelVectorEnv`` of N episodes
(arrays, what the rollout workers read, and PettingZoo dicts) against N ``rlbridge.parallel_env``
stepped one after the other, random actions for every agent, ``--steps`` steps. Runs of the
two kinds alternate (``--repeat``), and the table shows medians; "per CPU-s" divides by the
process's CPU time, the one-core figure. Both sides compute the same episodes (tests/test_vector_env.py).

"kernel alone" is the time spent inside the compiled step kernel during the same runs (every call
of it timed) and the aircraft-steps it took: transitions divided by that time is what the
environment could reach with everything else free, the bound of any vector engine on one core
for this traffic and kernel.

    python bench/bench_vector_env.py                                  # N = 16, 1 s decisions, nyc_train_100
    python bench/bench_vector_env.py --num-envs 16 --steps 300 --ids aamgym/CorridorSA-v1 aamgym/CorridorSA-v0
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import gymnasium

import aamsim.simulation
import aamsim.traffic.pool
import rlbridge
from rlbridge.vector import AamParallelVectorEnv

Timing = tuple[float, float, int, float, int]  # wall s, CPU s, transitions, kernel s, aircraft-steps


class KernelClock:
    """Times every call of the step kernel (the lone simulation's and the world set's) and counts its aircraft-steps.

    It replaces the kernel functions in the two modules that call them with timed wrappers
    (the modules look them up at each call); :meth:`reset` starts a new count.
    """

    def __init__(self) -> None:
        self.seconds = 0.0
        self.aircraft_steps = 0
        for module, name, ranges in ((aamsim.simulation, "advance", False),
                                     (aamsim.simulation, "advance_parallel", False),
                                     (aamsim.traffic.pool, "advance_ranges", True),
                                     (aamsim.traffic.pool, "advance_ranges_parallel", True)):
            setattr(module, name, self._timed(getattr(module, name), ranges))

    def reset(self) -> None:
        self.seconds = 0.0
        self.aircraft_steps = 0

    def _timed(self, kernel: Callable[..., tuple[int, int]], ranges: bool) -> Callable[..., tuple[int, int]]:
        def timed(*args: Any) -> tuple[int, int]:
            t0 = time.perf_counter()
            k, status = kernel(*args)
            self.seconds += time.perf_counter() - t0
            # advance(F, B, n, ...) steps n aircraft; advance_ranges(F, B, lo, hi, ...) the slots lo[b]..hi[b]-1.
            n = int((args[3] - args[2]).sum()) if ranges else int(args[2])
            self.aircraft_steps += n * k
            return k, status
        return timed


KERNEL = KernelClock()


def _timed(fn: Callable[[], int]) -> Timing:
    KERNEL.reset()
    c0, t0 = time.process_time(), time.perf_counter()
    count = fn()
    return time.perf_counter() - t0, time.process_time() - c0, count, KERNEL.seconds, KERNEL.aircraft_steps


def single_agent(env_id: str, mode: str, n: int, steps: int, seed: int, kwargs: dict) -> Timing:
    env = gymnasium.make_vec(env_id, num_envs=n, vectorization_mode=mode, **kwargs)
    env.reset(seed=seed)  # the first reset (every env flies to its ego) is not timed; autoresets are
    rng = np.random.default_rng(seed)
    actions = rng.integers(0, int(env.single_action_space.n), (steps, n))  # type: ignore[attr-defined]

    def run() -> int:
        for t in range(steps):
            env.step(actions[t])
        return steps * n

    out = _timed(run)
    env.close()
    return out


def multi_agent(kind: str, n: int, steps: int, seed: int, kwargs: dict) -> Timing:
    rng = np.random.default_rng(seed)
    if kind == "separate":
        envs = [rlbridge.parallel_env(**kwargs) for _ in range(n)]
        for k, env in enumerate(envs):
            env.reset(seed=seed + k)

        def run() -> int:
            count = 0
            for _ in range(steps):
                for env in envs:
                    if env.agents:
                        _, rewards, *_ = env.step(dict(zip(env.agents, rng.integers(0, 3, len(env.agents)).tolist())))
                        count += len(rewards)
            return count

        return _timed(run)
    vec = AamParallelVectorEnv(n, **kwargs)
    vec.reset(seed=seed)

    def run_vec() -> int:
        count = 0
        for _ in range(steps):
            actions = [dict(zip(agents, rng.integers(0, 3, len(agents)).tolist())) for agents in vec.agents]
            if kind == "arrays":
                count += sum(len(r.agents) for r in vec.step_results(actions).values())
            else:
                count += sum(len(r) for r in vec.step(actions)[1])
        return count

    out = _timed(run_vec)
    vec.close()
    return out


def _row(name: str, runs: list[Timing], unit: str) -> tuple[float, float]:
    wall = statistics.median(r[0] for r in runs)
    cpu = statistics.median(r[1] for r in runs)
    kernel = statistics.median(r[3] for r in runs)
    count, aircraft_steps = runs[0][2], runs[0][4]
    print(f"  {name:44} {count:9,d} {unit:13} {wall:8.2f} s {count / wall:12,.0f}/s {count / cpu:12,.0f}/CPU-s"
          f" {kernel:7.2f} s {aircraft_steps / count:8,.0f} {aircraft_steps / kernel / 1e6:7.1f} M/s"
          f" {count / kernel:12,.0f}/s", flush=True)
    return count / wall, count / cpu


_KERNEL_HEAD = "  kernel alone: wall  ac-steps each     speed       bound"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="nyc_train_100.scn")
    ap.add_argument("--num-envs", type=int, default=16)
    ap.add_argument("--steps", type=int, default=200, help="vector steps per measurement")
    ap.add_argument("--interval", type=float, default=1.0, help="decision interval [s]")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--ids", nargs="*", default=["aamgym/CorridorSA-v1"], help="single-agent env ids")
    ap.add_argument("--no-multi", action="store_true", help="skip the multi-agent table")
    args = ap.parse_args()
    n = args.num_envs
    kwargs = {"scenario": args.scenario, "decision_interval_s": args.interval}
    load = os.getloadavg()
    print(f"{args.scenario}, N = {n}, decision interval {args.interval:g} s, dt 0.05 s, {args.steps} vector steps, "
          f"random actions; {os.cpu_count()} CPUs, load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}")
    # Warm-up: Numba's cache, imports.
    single_agent(args.ids[0], "vector_entry_point", 2, 5, args.seed, kwargs)
    for env_id in args.ids:
        print(f"single agent, {env_id}:{'':20} transitions     wall         per s      per CPU-s{_KERNEL_HEAD}")
        native, sync = [], []
        for _ in range(args.repeat):
            native.append(single_agent(env_id, "vector_entry_point", n, args.steps, args.seed, kwargs))
            sync.append(single_agent(env_id, "sync", n, args.steps, args.seed, kwargs))
        a = _row(f"native AamVectorEnv (make_vec), N = {n}", native, "steps")
        b = _row(f"SyncVectorEnv of {n} envs", sync, "steps")
        print(f"  ratio native / sync: {a[0] / b[0]:.1f}x wall, {a[1] / b[1]:.1f}x per CPU-s")
    if args.no_multi:
        return
    print(f"multi agent, corridor_sa:{'':21} transitions     wall         per s      per CPU-s{_KERNEL_HEAD}")
    runs: dict[str, list[Timing]] = {"arrays": [], "dicts": [], "separate": []}
    for _ in range(args.repeat):
        for kind, timings in runs.items():
            timings.append(multi_agent(kind, n, args.steps, args.seed, kwargs))
    a = _row(f"AamParallelVectorEnv, N = {n}, arrays", runs["arrays"], "agent-trans.")
    d = _row(f"AamParallelVectorEnv, N = {n}, dicts", runs["dicts"], "agent-trans.")
    b = _row(f"{n} separate parallel_env", runs["separate"], "agent-trans.")
    print(f"  ratio vector (arrays) / separate: {a[0] / b[0]:.1f}x wall, {a[1] / b[1]:.1f}x per CPU-s; "
          f"dicts: {d[0] / b[0]:.1f}x")


if __name__ == "__main__":
    main()
