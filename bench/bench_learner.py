"""The learner alone: aircraft-states per second of ``learner.update``, eager and static paths side by side.

Plays a few episodes of ``nyc_train_100`` once with the initial policies (the batches a learner
gets in one iteration: two episodes, about 6,000-12,000 aircraft-states) and records them to a
cache directory outside the repository (``--cache``, default ``~/.cache/aamsim/bench_learner``);
later invocations reuse the recording, so every contender, device and path updates on exactly
the same batches. Then, per contender and device, it times ``update`` on them with

* ``old``: the eager path (``static=False``): what the learners ran before the static path, and
  still run on a CPU;
* ``new``: the static path (``static=True``): packed intruders padded to a fixed bucket, the
  whole gradient step in tensors of fixed shapes (captured once in a CUDA graph and replayed on
  CUDA; run eagerly on a CPU), fused Adam, no host read inside the update loop, DDQN's replay on
  the device.

Each (contender, device, path) gets a fresh learner with seed 0 and ``--repeats`` updates on the
batches; the first carries one-off costs (the bucket, the capture, the replay's allocation), so
the figure is the median of the others. On CUDA it also profiles one update (``torch.profiler``)
and prints the share of the update's wall time the GPU spent in kernels ("GPU busy").

DDQN's update makes the gradient steps its schedule calls for: ``ddqn`` (RLlib's ratio, one step
per 160 environment steps: a couple of steps per two episodes) and ``ddqn_per_transition`` (one
per 4 aircraft transitions); ``learning_starts`` is set to 0 here so that the first update already
trains.

    python bench/bench_learner.py                                  # cpu (1 thread), cuda when present
    python bench/bench_learner.py --devices cpu --threads 2 --contenders d2mava_a ddqn_per_transition
    python bench/bench_learner.py --json out.json
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import statistics
import sys
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CONTENDERS = ("d2mava_a", "d2mava_a_shared", "ddqn", "ddqn_per_transition")
DEFAULT_CACHE = Path.home() / ".cache" / "aamsim" / "bench_learner"
BATCH_FIELDS = ("values", "obs_idx", "next_idx", "actions", "logp", "rewards", "terminated", "truncated", "agent")


def paper_env(scenario: str) -> Any:
    """The training environment of ``aamgym train scenario=<scenario>`` (the paper's use case)."""
    from rlbridge.experiment.configstore import compose_config
    from rlbridge.experiment.train import env_spec_from

    return env_spec_from(compose_config("config", overrides=[f"scenario={scenario}"]))


def algorithm(name: str) -> tuple[str, dict[str, Any], str]:
    """(kind, params, label) of ``rlbridge/conf/algorithm/<name>.yaml``."""
    from omegaconf import OmegaConf

    from rlbridge.experiment.configstore import compose_config

    algo = compose_config("config", overrides=[f"algorithm={name}"]).algorithm
    params = dict(OmegaConf.to_container(algo.params, resolve=True))  # type: ignore[arg-type]
    return str(algo.kind), params, str(algo.label)


def save_batches(path: Path, batches: list[Any]) -> None:
    """Episode batches as one ``.npz`` of plain arrays (no pickled objects)."""
    arrays: dict[str, np.ndarray] = {}
    meta = []
    for i, b in enumerate(batches):
        for k, v in b.obs.items():
            arrays[f"{i}/obs/{k}"] = v
        for k in BATCH_FIELDS:
            arrays[f"{i}/{k}"] = getattr(b, k)
        meta.append({"agents": b.agents, "stats": asdict(b.stats), "obs": list(b.obs)})
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **arrays)
    tmp.replace(path)


def load_batches(path: Path) -> list[Any]:
    from rlbridge.agents.rollout import EpisodeBatch, EpisodeStats

    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(z["meta"].tobytes().decode())
        return [EpisodeBatch(obs={k: z[f"{i}/obs/{k}"] for k in m["obs"]},
                             **{k: z[f"{i}/{k}"] for k in BATCH_FIELDS}, agents=list(m["agents"]),
                             stats=EpisodeStats(**m["stats"]))
                for i, m in enumerate(meta)]


def recorded_batches(cache: Path, scenario: str, kind: str, episodes: int) -> list[Any]:
    """The episodes a ``kind`` learner trains on (its observation format), recorded once."""
    from rlbridge.agents import make_learner, usecase_dims
    from rlbridge.agents.core import episode_seed
    from rlbridge.agents.rollout import RolloutWorker

    fmt = "dict" if kind == "d2mava" else "flat"
    path = cache / f"{Path(scenario).stem}_{fmt}_{episodes}ep.npz"
    if path.exists():
        return load_batches(path)
    env = paper_env(scenario)
    name = "d2mava_a" if kind == "d2mava" else "ddqn"
    k, params, _ = algorithm(name)
    learner = make_learner(k, params, usecase_dims(env.usecase, env.params), "cpu", 0)
    worker = RolloutWorker(env, {"policy": learner.actor_spec(k)})
    print(f"recording {episodes} episodes of {scenario} ({fmt} observations) to {path}", flush=True)
    batches = worker.collect([episode_seed(0, 1, 0, e) for e in range(episodes)], "policy", learner.weights(),
                             learner.explore(0, 0))
    save_batches(path, batches)
    return load_batches(path)


def gpu_busy(learner: Any, batches: list[Any]) -> float:
    """Share of one update's wall time the GPU spent in kernels (torch.profiler)."""
    import torch
    from torch.profiler import ProfilerActivity, profile

    torch.cuda.synchronize()
    with profile(activities=[ProfilerActivity.CPU, ProfilerActivity.CUDA]) as prof:
        t0 = time.perf_counter()
        learner.update(batches)
        torch.cuda.synchronize()
        wall = time.perf_counter() - t0
    kernel_us = sum(e.self_device_time_total for e in prof.key_averages() if e.device_type.name == "CUDA")
    return kernel_us * 1e-6 / wall


def time_updates(name: str, device: str, static: bool, batches: list[Any], dims: dict[str, Any], repeats: int,
                 profile: bool) -> dict[str, Any]:
    import torch

    from rlbridge.agents import make_learner

    kind, params, label = algorithm(name)
    if kind == "dqn":
        params["learning_starts"] = 0
    learner = make_learner(kind, params, dims, device, 0, static=static)
    states = sum(len(b) for b in batches)
    times, steps = [], []
    for _ in range(repeats):
        before = getattr(learner, "gradient_steps", getattr(learner, "updates", 0))
        if device.startswith("cuda"):
            torch.cuda.synchronize()
        t0 = time.perf_counter()
        learner.update(batches)
        if device.startswith("cuda"):
            torch.cuda.synchronize()
        times.append(time.perf_counter() - t0)
        steps.append(getattr(learner, "gradient_steps", getattr(learner, "updates", 0)) - before)
    steady = statistics.median(times[1:]) if len(times) > 1 else times[0]
    out = {"contender": name, "label": label, "device": device, "path": "new" if static else "old",
           "aircraft_states": states, "first_update_s": times[0], "update_s": steady,
           "states_per_s": states / steady, "gradient_steps_per_update": statistics.median(steps),
           "threads": torch.get_num_threads()}
    if profile and device.startswith("cuda"):
        out["gpu_busy"] = gpu_busy(learner, batches)
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--contenders", nargs="+", default=list(CONTENDERS), choices=CONTENDERS)
    ap.add_argument("--devices", nargs="+", default=None, help="cpu and/or cuda (default: cpu, and cuda when present)")
    ap.add_argument("--threads", type=int, default=1, help="PyTorch threads on the CPU")
    ap.add_argument("--repeats", type=int, default=3, help="updates per measurement (the first is not counted)")
    ap.add_argument("--episodes", type=int, default=2, help="episodes in the recorded batches (one iteration)")
    ap.add_argument("--scenario", default="nyc_train_100")
    ap.add_argument("--cache", type=Path, default=DEFAULT_CACHE, help="where the recorded batches are kept")
    ap.add_argument("--json", type=Path, default=None, help="also write the figures here")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    import torch

    from rlbridge.experiment.train import resolve_device

    devices = args.devices or (["cpu", "cuda"] if torch.cuda.is_available() else ["cpu"])
    for d in devices:
        resolve_device(d)  # a clear error now, not after the recording
    torch.set_num_threads(args.threads)
    gpu = torch.cuda.get_device_name() if torch.cuda.is_available() else "none"
    print(f"{os.cpu_count()} CPUs, {args.threads} PyTorch thread(s) on the CPU, GPU: {gpu}; "
          f"load average {os.getloadavg()[0]:.2f}")
    from rlbridge.agents import usecase_dims

    env = paper_env(args.scenario)
    dims = usecase_dims(env.usecase, env.params)
    results = []
    for name in args.contenders:
        kind = algorithm(name)[0]
        batches = recorded_batches(args.cache, args.scenario, kind, args.episodes)
        for device in devices:
            for static in (False, True):  # old then new, back to back on the same batches
                r = time_updates(name, device, static, batches, dims, args.repeats, profile=True)
                results.append(r)
                busy = f", GPU busy {100 * r['gpu_busy']:.0f} %" if "gpu_busy" in r else ""
                print(f"  {name:20s} {device:5s} {r['path']:3s} {r['states_per_s']:9.0f} aircraft-states/s "
                      f"({r['aircraft_states']:,} states, {r['gradient_steps_per_update']:.0f} gradient steps in "
                      f"{r['update_s']:.2f} s; first update {r['first_update_s']:.2f} s{busy}; "
                      f"load {os.getloadavg()[0]:.2f})", flush=True)
    print()
    print("| contender | device | old [states/s] | new [states/s] | new / old | GPU busy old / new |")
    print("|---|---|---|---|---|---|")
    for name in args.contenders:
        for device in devices:
            old, new = ({r["path"]: r for r in results if r["contender"] == name and r["device"] == device}[p]
                        for p in ("old", "new"))
            busy = (f"{100 * old['gpu_busy']:.0f} % / {100 * new['gpu_busy']:.0f} %" if "gpu_busy" in old else "n/a")
            dev = f"{device} ({old['threads']} thread{'s' * (old['threads'] > 1)})" if device == "cpu" else device
            print(f"| {name} | {dev} | {old['states_per_s']:.0f} | {new['states_per_s']:.0f} | "
                  f"{new['states_per_s'] / old['states_per_s']:.2f}x | {busy} |")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
