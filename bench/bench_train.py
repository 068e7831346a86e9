"""Whole training runs (rollouts + learner updates) in aircraft-states per second, old vs new path.

Runs ``aamgym train``'s loop (:func:`rlbridge.experiment.train.run_training`, the real Ray
workers, the real learner) for a fixed number of iterations per run (the same work for both paths) on ``nyc_train_100`` with the
paper's hyper-parameters, once per (algorithm, path), in this one process on this one machine,
and prints aircraft-states per second of each path side by side with their ratio: after the first
iteration (steady state, the figure that decides a multi-hour run) and over the whole run (the
first iteration carries the workers' start-up). An
aircraft-state is one agent decision (what the learning curves count).

* ``old``: the loop as it was before the overlap (``train.mode=serial``): every iteration the
  workers play, then the learner updates while they wait; 2 Ray workers, one episode each;
  D2MAV-A's update runs the attention over all 30 padded intruder slots.
* ``new``: ``train.mode=overlap``: the workers keep playing the next iteration (policy lag of one
  update, docs/algorithms.md) while the learner updates; one Ray worker plays the iteration's
  two episodes in lockstep with one batched forward pass over the aircraft of both; D2MAV-A's
  update attends over the valid intruders only (``packed_attention``, same loss and gradients);
  the learner's PyTorch takes the CPUs the worker leaves (``train.torch_threads=auto``).

Both paths put two episodes in an iteration, so each update sees the same amount of data.
The machine's load average is printed before and after each run: on a shared machine the
figures are only comparable within one invocation.

``--against REV`` compares commits instead of paths: the committed tree at ``REV`` (``git
archive``, in a temporary directory) and this source tree each run the given paths in their own
process, alternating per contender, in this one invocation (each tree first plays a one-iteration
warm-up so that both have compiled their Numba kernels before anything is timed).

    python bench/bench_train.py                              # 12 iterations per run, all three contenders
    python bench/bench_train.py --iterations 8 --algorithms d2mava_a --paths old new
    python bench/bench_train.py --json out.json
    python bench/bench_train.py --against 5349319 --paths new --algorithms ddqn d2mava_a
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

# The two paths, as Hydra overrides of rlbridge/conf/config.yaml.
PATHS: dict[str, list[str]] = {
    "old": ["train.mode=serial", "workers=2", "train.episodes_per_worker=1", "train.torch_threads=1"],
    "new": ["train.mode=overlap", "workers=1", "train.episodes_per_worker=2", "train.torch_threads=auto"],
}
ALGORITHMS = ("d2mava_a", "ddqn", "d2mava_a_shared")


def path_overrides(path: str, algorithm: str) -> list[str]:
    """The old path also runs the old padded attention in D2MAV-A's update."""
    if path == "old" and algorithm.startswith("d2mava"):
        return [*PATHS[path], "algorithm.params.packed_attention=false"]
    return list(PATHS[path])


def steady_rate(run: Path) -> float:
    """Aircraft-states per second after the first iteration (which carries the workers' start-up:
    Ray actors importing PyTorch and loading the compiled kernels, 20-30 s on 2 busy cores)."""
    with open(run / "learning_curve.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    if len(rows) < 2:
        return float("nan")
    states = sum(int(r["aircraft_states"]) for r in rows[1:])
    return states / (float(rows[-1]["wall_s"]) - float(rows[0]["wall_s"]))


def run_one(algorithm: str, path: str, iterations: int, scenario: str, out: Path, extra: list[str]) -> dict[str, Any]:
    """One training run of ``iterations`` iterations; its training summary plus the load around it."""
    from rlbridge.experiment.configstore import compose_config
    from rlbridge.experiment.train import run_training

    overrides = [f"algorithm={algorithm}", f"scenario={scenario}", f"train.iterations={iterations}",
                 "train.baseline_episodes=0", "train.checkpoint_every=0", "seed=0", *path_overrides(path, algorithm), *extra]
    cfg = compose_config("config", overrides=overrides)
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    run = out / f"{algorithm}_{path}"
    summary = run_training(cfg, run)
    return {"algorithm": algorithm, "path": path, "states_per_s": steady_rate(run), "whole_run_states_per_s":
            summary["states_per_s"],
            "aircraft_states": summary["aircraft_states"], "iterations": summary["iterations"],
            "train_wall_s": summary["wall_s"], "rollout_wait_s": summary["rollout_s"],
            "run_wall_s": time.perf_counter() - t0, "load_before": load0, "load_after": os.getloadavg(),
            "overrides": overrides}


def tree_at(rev: str, dest: Path) -> Path:
    """The committed tree of this repository at ``rev``, written to ``dest`` (``git archive``)."""
    dest.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", rev], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


def run_in_tree(tree: Path, algorithm: str, args: argparse.Namespace, out: Path) -> list[dict[str, Any]]:
    """This benchmark, run by ``tree``'s own copy of it in a fresh process on ``tree``'s code."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    cmd = [sys.executable, str(tree / "bench" / "bench_train.py"), "--iterations", str(args.iterations),
           "--algorithms", algorithm, "--paths", *args.paths, "--scenario", args.scenario, "--json", str(out),
           *args.overrides]
    subprocess.run(cmd, env=env, check=True, cwd=tree, stdout=subprocess.DEVNULL)
    return json.loads(out.read_text())


def compare_trees(args: argparse.Namespace) -> list[dict[str, Any]]:
    """``--against``: the base commit's tree and this one, alternating per contender."""
    results: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        trees = {args.against: tree_at(args.against, Path(tmp) / "base"), "this tree": ROOT}
        for name, tree in trees.items():  # warm-up: Numba compiles into each tree's own cache
            warm = argparse.Namespace(**{**vars(args), "iterations": 1, "paths": args.paths[:1]})
            run_in_tree(tree, args.algorithms[0], warm, Path(tmp) / "warmup.json")
        for algo in args.algorithms:
            for name, tree in trees.items():
                for r in run_in_tree(tree, algo, args, Path(tmp) / "out.json"):
                    r["tree"] = name
                    results.append(r)
                    print(f"  {name:12s} {algo:16s} {r['path']:4s} {r['states_per_s']:8.0f} aircraft-states/s after "
                          f"iteration 1, {r['whole_run_states_per_s']:.0f} over the whole run "
                          f"({r['aircraft_states']:,} states in {r['train_wall_s']:.0f} s; "
                          f"load {r['load_before'][0]:.2f} -> {r['load_after'][0]:.2f})", flush=True)
    print()
    print(f"| algorithm | path | {args.against} [states/s] | this tree [states/s] | ratio | whole run: "
          f"{args.against} | this tree | ratio |")
    print("|---" * 8 + "|")
    for algo in args.algorithms:
        for path in args.paths:
            base, new = ({r["tree"]: r for r in results if r["algorithm"] == algo and r["path"] == path}[k]
                         for k in (args.against, "this tree"))
            print(f"| {algo} | {path} | {base['states_per_s']:.0f} | {new['states_per_s']:.0f} | "
                  f"{new['states_per_s'] / base['states_per_s']:.2f}x | {base['whole_run_states_per_s']:.0f} | "
                  f"{new['whole_run_states_per_s']:.0f} | "
                  f"{new['whole_run_states_per_s'] / base['whole_run_states_per_s']:.2f}x |")
    return results


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--iterations", type=int, default=12,
                    help="iterations of each run (2 episodes, about 12,500 aircraft-states each)")
    ap.add_argument("--algorithms", nargs="+", default=list(ALGORITHMS), choices=[*ALGORITHMS, "ddqn_per_transition"])
    ap.add_argument("--paths", nargs="+", default=list(PATHS), choices=list(PATHS))
    ap.add_argument("--scenario", default="nyc_train_100")
    ap.add_argument("--json", type=Path, default=None, help="also write the figures here")
    ap.add_argument("--against", default=None, metavar="REV",
                    help="compare this source tree with the committed tree at REV (each runs --paths)")
    ap.add_argument("overrides", nargs="*", help="more Hydra overrides for every run (e.g. device=cuda)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    print(f"{os.cpu_count()} CPUs; load average at start {os.getloadavg()[0]:.2f}; {args.iterations} iterations per run")
    if args.against:
        results = compare_trees(args)
        if args.json:
            args.json.write_text(json.dumps(results, indent=2) + "\n")
        return
    results: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for algo in args.algorithms:
            for path in args.paths:
                r = run_one(algo, path, args.iterations, args.scenario, Path(tmp), list(args.overrides))
                results.append(r)
                print(f"  {algo:16s} {path:4s} {r['states_per_s']:8.0f} aircraft-states/s after iteration 1, "
                      f"{r['whole_run_states_per_s']:.0f} over the whole run "
                      f"({r['aircraft_states']:,} states, {r['iterations']} iterations in {r['train_wall_s']:.0f} s; "
                      f"load {r['load_before'][0]:.2f} -> {r['load_after'][0]:.2f})", flush=True)
    print()
    print(f"| algorithm | {' | '.join(f'{p} [states/s]' for p in args.paths)} |"
          + (" new / old |" if {"old", "new"} <= set(args.paths) else ""))
    print("|---" * (len(args.paths) + 1 + ({"old", "new"} <= set(args.paths))) + "|")
    for algo in args.algorithms:
        rate = {r["path"]: r["states_per_s"] for r in results if r["algorithm"] == algo}
        row = f"| {algo} | " + " | ".join(f"{rate[p]:.0f}" for p in args.paths) + " |"
        if {"old", "new"} <= set(rate):
            row += f" {rate['new'] / rate['old']:.2f}x |"
        print(row)
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
