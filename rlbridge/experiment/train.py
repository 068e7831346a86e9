"""``aamgym train``: the training loop (Hydra app; config in ``rlbridge/conf/config.yaml``).

One iteration = every worker returns ``train.episodes_per_worker`` episodes played with the
current weights (the paper: "each training iteration is composed of N_workers simulation
returns"), then the learner updates on them (``train.mode=serial``). With
``train.mode=overlap`` the workers play iteration k+1 while the learner updates on iteration
k, so iteration k is played with the weights after update k-2 (a policy lag of exactly one
update; docs/algorithms.md, "Training loop"). The run directory receives:

* ``resolved_config.yaml`` — the full configuration of the run;
* ``learning_curve.csv`` — one row per iteration (:data:`CURVE_COLUMNS`);
* ``baseline.json`` — the unequipped aircraft on the training scenario (reference line);
* ``checkpoints/last.pt`` every ``train.checkpoint_every`` iterations and at the end;
  ``checkpoints/best.pt`` — the weights at the best ``train.best_window``-iteration rolling
  mean of the reward (the paper: 25);
* ``training_summary.json`` — totals, aircraft-states per second, the best iteration.

``train.resume=<run dir or .pt>`` continues from a checkpoint (iteration, weights,
optimiser, counters and RNG states; the DDQN replay memory starts empty).

Ctrl-C (SIGINT) or ``kill`` (SIGTERM) stops the run at the next iteration boundary: the iteration being
played is learned from, ``last.pt`` is written, no ``training_summary.json`` (the run is not finished),
and :class:`TrainingStopped` is raised (``aamgym train`` and ``aamgym study`` exit with status 130 and
say how to continue). ``train.resume`` then continues it exactly as if it had not stopped. A second
signal stops at once (the last ``checkpoint_every`` iterations are lost).
"""

from __future__ import annotations

import csv
import json
import logging
import os
import re
import shutil
import signal
import time
from collections import OrderedDict
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf

from aamsim.stop_signals import StopSignals
from rlbridge.agents import make_learner, usecase_dims
from rlbridge.agents.capture import check_device
from rlbridge.agents.core import episode_seed, rolling_mean
from rlbridge.agents.rollout import EnvSpec, EpisodeBatch, EpisodeStats
from rlbridge.experiment.workers import make_pool
from rlbridge.usecases.registry import usecase_spec
from rlbridge.usecases.spec import SEPARATION_CURVE, CurveColumn

log = logging.getLogger("aamgym.train")

CHECKPOINT_FORMAT = 1
TRAIN_MODES = ("serial", "overlap")
LEARNER_STATS = ("policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction", "explained_variance",
                 "td_loss", "epsilon", "gradient_steps")
# learning_curve.csv: these, the use case's own columns (UseCaseSpec.curve), then CURVE_TAIL.
CURVE_HEAD = ("iteration", "wall_s", "sim_s", "episodes", "reward_mean", "reward_std", "episode_rewards")
CURVE_TAIL = ("aircraft_states", "aircraft_states_total", "states_per_s", "rollout_s", "update_s") + LEARNER_STATS


def curve_columns(curve: tuple[CurveColumn, ...] = SEPARATION_CURVE) -> tuple[str, ...]:
    """The header of a learning curve whose use case declares ``curve`` (default: the separation rates)."""
    return CURVE_HEAD + tuple(c.name for c in curve) + CURVE_TAIL


CURVE_COLUMNS = curve_columns()  # the corridor's (and every use case's that declares no curve of its own)


@dataclass
class TrainState:
    """Counters carried across checkpoints."""

    iteration: int = 0
    transitions: int = 0  # aircraft-states collected
    env_steps: int = 0  # environment steps (decisions of the multi-agent environment) collected
    episodes: int = 0
    wall_s: float = 0.0  # training wall-clock time [s], resumed runs included
    rollout_s: float = 0.0  # of which waiting for the workers' episodes [s]
    rewards: list[float] = field(default_factory=list)  # reward_mean per iteration
    best: float = -float("inf")  # best rolling mean so far
    best_iteration: int = 0


def learner_threads(setting: Any, workers: int) -> int:
    """PyTorch threads of the learner: a number, or ``auto``: the CPUs the Ray workers leave free.

    Each worker holds one CPU (its own PyTorch runs one thread); an in-process worker shares
    the learner's process, where one thread is fastest for its small inference batches.
    """
    if str(setting) != "auto":
        n = int(setting)
        if n < 1:
            raise ValueError(f"train.torch_threads must be >= 1 or auto, not {setting!r}")
        return n
    if workers <= 0:
        return 1
    return max(1, (os.cpu_count() or 1) - workers)


def resolve_device(name: str) -> str:
    """``auto``: cuda when there is a GPU, else cpu; any other name is checked here
    (:func:`~rlbridge.agents.capture.check_device`: a ValueError saying why it cannot be used)."""
    if name == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    return str(check_device(name))


def resolve_workers(setting: Any, device: str, cores: int | None = None) -> int:
    """Rollout workers: a number, or ``auto``: the cores the learner leaves.

    With the learner on CUDA its process needs one core to drive the GPU and every other core
    plays episodes (``cores - 1``); on a CPU the learner computes with the cores the workers
    leave (``train.torch_threads=auto``), so the workers take half of them. At least 1.
    """
    if str(setting) != "auto":
        n = int(setting)
        if n < 0:
            raise ValueError(f"workers must be >= 0 or auto, not {setting!r}")
        return n
    cores = int(cores or os.cpu_count() or 1)
    return max(1, cores - 1 if device.startswith("cuda") else cores // 2)


def resolve_scenario_path(name: str) -> str:
    """Absolute path of a scenario name or path (remote workers may run elsewhere)."""
    from aamsim.scenarios import resolve_scenario

    path = resolve_scenario(name)
    if path is None:
        raise FileNotFoundError(f"scenario not found: {name} (neither a file nor a scenario shipped in aamsim/scn)")
    return str(Path(path).resolve())


ZMQ_ADDRESS = re.compile(r"(tcp://[^\s:/]+|tcp://\[[0-9a-fA-F:]+\]):\d{1,5}|ipc://\S+")


def env_spec_from(cfg: DictConfig, scenario: str | None = None, **params: Any) -> EnvSpec:
    """The episodes of a run: ``cfg``'s scenario, use case and parameters on its backend (``backend``,
    ``address``: ``backend=zmq address=tcp://host:port`` plays them on a simulation server)."""
    up = dict(OmegaConf.to_container(cfg.usecase.params, resolve=True))  # type: ignore[arg-type]
    up.update(params)
    backend = str(cfg.get("backend") or "local")
    address = cfg.get("address")
    if backend == "zmq":
        if not address or not ZMQ_ADDRESS.fullmatch(str(address)):
            raise ValueError(f"backend=zmq needs address=tcp://host:port, the simulation server's address as "
                             f"`aamsim serve` prints it; got address={address!r}")
        # The server resolves the scenario name in its own scenario folders.
        name = str(scenario or cfg.scenario)
    else:
        name = resolve_scenario_path(scenario or cfg.scenario)
    return EnvSpec(name, str(cfg.usecase.name), up,
                   None if cfg.env.time_limit_s is None else float(cfg.env.time_limit_s), float(cfg.env.dt),
                   tuple(cfg.metrics), backend=backend, address=None if address is None else str(address),
                   timeout_s=float(cfg.get("timeout_s") or 30.0))


def find_checkpoint(path: str | Path, which: str = "last") -> Path:
    """A checkpoint file, or ``<run dir>/checkpoints/<which>.pt``."""
    p = Path(path)
    if p.is_file():
        return p
    cand = p / "checkpoints" / f"{which}.pt"
    if cand.is_file():
        return cand
    raise FileNotFoundError(f"no checkpoint {cand}")


class UntrustedCheckpointError(ValueError):
    """A checkpoint file that is not plain data (tensors, numbers, strings, lists, dicts)."""


def plain_data(x: Any, where: str = "checkpoint") -> Any:
    """``x`` as the plain data ``torch.load(weights_only=True)`` accepts, or a TypeError naming the field.

    numpy arrays become tensors, numpy scalars Python numbers, paths strings; anything else that is
    not a tensor, number, string, None, list, tuple or dict is refused at save time, so that every
    checkpoint written here loads without unpickling objects.
    """
    if x is None or isinstance(x, (bool, int, float, str, torch.Tensor, torch.Size, torch.dtype, torch.device)):
        return x
    if isinstance(x, np.ndarray):
        return torch.from_numpy(np.ascontiguousarray(x))
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    if isinstance(x, dict):
        out = {k if isinstance(k, (str, int)) else str(k): plain_data(v, f"{where}.{k}") for k, v in x.items()}
        if isinstance(x, OrderedDict):  # a module's state_dict: keep its version metadata
            kept = OrderedDict(out)
            if hasattr(x, "_metadata"):
                kept._metadata = plain_data(x._metadata, f"{where}._metadata")  # type: ignore[attr-defined]
            return kept
        return out
    if isinstance(x, (list, tuple)):
        return type(x)(plain_data(v, f"{where}[{i}]") for i, v in enumerate(x))
    raise TypeError(f"{where}: {type(x).__name__} cannot be stored in a checkpoint (plain data only)")


def load_checkpoint(path: str | Path) -> dict[str, Any]:
    """Read a checkpoint written by :func:`save_checkpoint`.

    Loads with ``weights_only=True``: tensors and plain containers only, so a checkpoint from
    someone else cannot run code. A file carrying any other object is refused with
    :class:`UntrustedCheckpointError` (checkpoints of earlier versions hold only plain data and
    load unchanged; see docs/algorithms.md, "Checkpoints").
    """
    import pickle

    try:
        ckpt = torch.load(Path(path), map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as exc:
        first = str(exc).strip().splitlines()
        raise UntrustedCheckpointError(
            f"{path}: refused: the checkpoint holds objects other than tensors and plain data, which would "
            f"run code when unpickled ({first[0] if first else 'unpickling refused'})") from None
    if not isinstance(ckpt, dict) or ckpt.get("format") != CHECKPOINT_FORMAT:
        got = ckpt.get("format") if isinstance(ckpt, dict) else type(ckpt).__name__
        raise ValueError(f"{path}: not an aamgym checkpoint (format {got})")
    return ckpt


def save_checkpoint(path: Path, learner: Any, state: TrainState, meta: dict[str, Any]) -> None:
    """Write atomically; the payload is checked to be plain data (:func:`plain_data`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    payload = plain_data({"format": CHECKPOINT_FORMAT, **meta, "learner": learner.state_dict(),
                          "state": asdict(state), "torch_rng": torch.get_rng_state()})
    torch.save(payload, tmp)
    tmp.replace(path)


def summarize_episodes(stats: list[EpisodeStats], curve: tuple[CurveColumn, ...] = SEPARATION_CURVE
                       ) -> dict[str, Any]:
    """The iteration's (or the baseline's) means: reward per aircraft, the use case's ``curve`` columns
    (those of each episode left out), aircraft-states, environment steps, simulated and wall seconds."""
    rewards = np.array([s.reward_per_aircraft for s in stats])
    means = {c.name: float(np.mean([c.value(s.metrics, s.aircraft) for s in stats]))
             for c in curve if not c.each_episode}
    return {"episodes": len(stats), "reward_mean": float(rewards.mean()), "reward_std": float(rewards.std()),
            **means,
            "aircraft_states": int(sum(s.transitions for s in stats)),
            "env_steps": int(sum(s.env_steps for s in stats)),
            "sim_s": float(sum(s.sim_s for s in stats)), "wall_s": float(sum(s.wall_s for s in stats))}


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _curve_text(means: dict[str, Any], curve: tuple[CurveColumn, ...], sep: str = ", ") -> str:
    """The use case's mean curve columns for a log line (``, nmac_per_aircraft 0.0100, ...``)."""
    return "".join(f"{sep}{c.name} {means[c.name]:.4f}" for c in curve if not c.each_episode)


def curve_row_values(stats: list[EpisodeStats], curve: tuple[CurveColumn, ...], means: dict[str, Any]
                     ) -> dict[str, str]:
    """The use case's curve columns of one iteration: the means of ``means`` (:func:`summarize_episodes`)
    and each episode's values, ``;``-separated."""
    return {c.name: ";".join(_fmt(c.value(s.metrics, s.aircraft)) for s in stats) if c.each_episode
            else _fmt(means[c.name]) for c in curve}


def _header(path: Path) -> list[str] | None:
    with open(path, newline="") as fh:
        return next(csv.reader(fh), None)


class CurveWriter:
    """Appends rows to learning_curve.csv (the header once).

    A file that exists keeps its own header (a run resumed, or a curve written before its use case
    declared its own columns): rows are written under it, unknown columns left out.
    """

    def __init__(self, path: Path, columns: tuple[str, ...] = CURVE_COLUMNS):
        self.path = path
        header = _header(path) if path.exists() else None
        if not header:
            with open(path, "w", newline="") as fh:
                csv.writer(fh).writerow(columns)
        self.columns = tuple(header) if header else columns

    def write(self, row: dict[str, Any]) -> None:
        with open(self.path, "a", newline="") as fh:
            csv.DictWriter(fh, self.columns, restval="", extrasaction="ignore").writerow(row)


def copy_curve(src: Path, dst: Path, upto: int) -> None:
    """The rows of a previous run's curve up to iteration ``upto`` (resumed runs), under its header."""
    if not src.exists():
        return
    with open(src, newline="") as fh:
        reader = csv.DictReader(fh)
        rows = [r for r in reader if int(r["iteration"]) <= upto]
        columns = tuple(reader.fieldnames or CURVE_COLUMNS)
    writer = CurveWriter(dst, columns)
    for r in rows:
        writer.write(r)


def discard_after(run_dir: Path, iteration: int) -> None:
    """Resuming a run in its own directory: forget what it did after the checkpoint's ``iteration``.

    Those iterations are played again (their episode seeds follow from the iteration), so their
    curve rows go, and a ``best.pt`` chosen among them goes too (the rolling mean is rebuilt).
    """
    curve = run_dir / "learning_curve.csv"
    if curve.exists():
        with open(curve, newline="") as fh:
            reader = csv.DictReader(fh)
            rows = [r for r in reader if int(r["iteration"]) <= iteration]
            columns = list(reader.fieldnames or CURVE_COLUMNS)
        tmp = curve.with_suffix(".tmp")
        with open(tmp, "w", newline="") as fh:
            writer = csv.DictWriter(fh, columns, restval="", extrasaction="ignore")
            writer.writeheader()
            writer.writerows(rows)
        tmp.replace(curve)
    best = run_dir / "checkpoints" / "best.pt"
    if best.exists() and int(load_checkpoint(best)["state"]["iteration"]) > iteration:
        best.unlink()


# What "the code" of a run is: the installed packages' sources and their build files. Results, docs and tests
# written in the same checkout (a study's own files, a parked checkpoint removed) do not make a run "+dirty".
CODE_PATHS = ("aamsim", "rlbridge", "uamtoolkit_import", "setup.py", "setup.cfg", "pyproject.toml",
              "aamsim_bluesky.pth")


def code_version(root: Path | None = None) -> dict[str, str]:
    """What code made a run: the package version and, in a git checkout, the commit (``+dirty`` when the
    package sources, :data:`CODE_PATHS`, had uncommitted changes). ``root``: the checkout (default: this one)."""
    import subprocess

    from aamsim import __version__

    out = {"aamsim": __version__}
    root = Path(__file__).resolve().parents[2] if root is None else Path(root)
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                                timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no", "--",
                                *CODE_PATHS], capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return out
    if commit:
        out["commit"] = commit + ("+dirty" if dirty else "")
    return out


@dataclass
class TrainingRun:
    """What :func:`build_training` sets up for a run: its configuration, learner, counters and files."""

    cfg: DictConfig
    run_dir: Path
    device: str
    n_workers: int
    env: EnvSpec
    learner: Any
    state: TrainState
    meta: dict[str, Any]
    columns: tuple[CurveColumn, ...]  # the use case's learning-curve columns
    overlap: bool
    behaviour: Any = None  # overlap: the weights the next iteration is played with (None: the learner's)

    @property
    def ckpt_dir(self) -> Path:
        return self.run_dir / "checkpoints"


def build_training(cfg: DictConfig, run_dir: str | Path) -> TrainingRun:
    """Resolve the device and workers, write the resolved configuration, build the learner, resume."""
    device = resolve_device(str(cfg.device))  # a clear error before anything starts
    n_workers = resolve_workers(cfg.workers, device)
    cfg.workers = n_workers  # the run's resolved configuration records the number (workers=auto)
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    if not (cfg.train.resume and (run_dir / "resolved_config.yaml").exists()):
        # A run continued in place keeps the configuration it started with (no resume path in it).
        (run_dir / "resolved_config.yaml").write_text(OmegaConf.to_yaml(cfg, resolve=True))
    tc = cfg.train
    torch.set_num_threads(learner_threads(tc.torch_threads, n_workers))
    algo = cfg.algorithm
    env = env_spec_from(cfg)
    dims = usecase_dims(env.usecase, env.params)
    params = dict(OmegaConf.to_container(algo.params, resolve=True))  # type: ignore[arg-type]
    static = str(tc.get("static_learner", "auto")).lower()
    if static not in ("auto", "true", "false"):
        raise ValueError(f"train.static_learner={static!r}: auto, true or false")
    learner = make_learner(str(algo.kind), params, dims, device, int(cfg.seed),
                           None if static == "auto" else static == "true")
    mode = str(tc.get("mode", "serial"))
    if mode not in TRAIN_MODES:
        raise ValueError(f"train.mode={mode!r}: one of {', '.join(TRAIN_MODES)}")
    meta: dict[str, Any] = {
        "algorithm": {"name": str(algo.name), "kind": str(algo.kind), "label": str(algo.get("label", algo.name)),
                      "params": params},
        "dims": dims, "env": asdict(env), "seed": int(cfg.seed), "run_dir": str(run_dir.resolve()),
        "config": OmegaConf.to_container(cfg, resolve=True), "code": [code_version()]}
    run = TrainingRun(cfg, run_dir, device, n_workers, env, learner, TrainState(), meta,
                      usecase_spec(env.usecase).curve, mode == "overlap")
    if tc.resume:
        resume_training(run, str(tc.resume))
    return run


def resume_training(run: TrainingRun, resume: str) -> None:
    """Continue from the last checkpoint of ``resume``: weights, RNG, counters, and the run's files."""
    algo = run.cfg.algorithm
    src = find_checkpoint(resume, "last")
    ckpt = load_checkpoint(src)
    if ckpt["algorithm"]["kind"] != algo.kind:
        raise ValueError(f"cannot resume a {ckpt['algorithm']['kind']} checkpoint as {algo.kind}")
    run.learner.load_state_dict(ckpt["learner"])
    torch.set_rng_state(ckpt["torch_rng"])
    # Every code version that trained part of this run (a study resumed across commits lists each).
    run.meta["code"] = [c for c in ckpt.get("code", []) if c != run.meta["code"][0]] + run.meta["code"]
    run.state = state = TrainState(**ckpt["state"])
    if run.overlap and "behaviour_weights" in ckpt:  # the weights the next iteration was to be played with
        run.behaviour = {k: v.numpy() for k, v in ckpt["behaviour_weights"].items()}
    src_run, run_dir = Path(ckpt["run_dir"]), run.run_dir
    if src_run.resolve() == run_dir.resolve():
        discard_after(run_dir, state.iteration)
    else:
        copy_curve(src_run / "learning_curve.csv", run_dir / "learning_curve.csv", state.iteration)
        for name in ("baseline.json",):
            if (src_run / name).exists():
                shutil.copy(src_run / name, run_dir / name)
        if (src_run / "checkpoints" / "best.pt").exists():
            run.ckpt_dir.mkdir(exist_ok=True)
            shutil.copy(src_run / "checkpoints" / "best.pt", run.ckpt_dir / "best.pt")
    log.info("resumed from %s at iteration %d (%d aircraft-states)", src, state.iteration, state.transitions)


def play_baseline(run: TrainingRun, pool: Any) -> None:
    """The unequipped episodes on the training scenario (``baseline.json``), the curves' reference; once."""
    tc, run_dir = run.cfg.train, run.run_dir
    if int(tc.baseline_episodes) <= 0 or (run_dir / "baseline.json").exists():
        return
    slots = max(run.n_workers, 1)
    seeds = [episode_seed(int(run.cfg.seed), 0, k % slots, k // slots) for k in range(int(tc.baseline_episodes))]
    lists = [seeds[w::slots] for w in range(slots)]
    base = [s for part in pool.collect(lists, "unequipped", record=False) for s in part]
    base_summary = summarize_episodes(base, run.columns)
    (run_dir / "baseline.json").write_text(json.dumps({"policy": "unequipped", **base_summary,
                                                        "seeds": seeds}, indent=2) + "\n")
    log.info("unequipped baseline: reward/aircraft %.4f%s over %d episodes", base_summary["reward_mean"],
             _curve_text(base_summary, run.columns), len(base))


class TrainingStopped(KeyboardInterrupt):
    """A stop signal ended the run at an iteration boundary: ``last.pt`` holds it, ``train.resume`` continues it.

    A KeyboardInterrupt, so that whatever runs the training (the study, a script) stops as it would on
    Ctrl-C; ``run_dir`` and ``iteration`` say where the run stands."""

    def __init__(self, run_dir: Path, iteration: int, signal_name: str):
        super().__init__(f"{signal_name}: training stopped after iteration {iteration}; {run_dir / 'checkpoints'}"
                         f"/last.pt holds it, train.resume={run_dir} continues it")
        self.run_dir, self.iteration, self.signal_name = run_dir, iteration, signal_name


class Budget:
    """When the run stops: ``train.iterations``, ``train.aircraft_states``, ``train.hours`` (100 iterations
    when none is set), or a stop signal (``stop_requested``: its name) before the budget is spent."""

    def __init__(self, tc: Any, t_start: float):
        self.max_iter = tc.iterations
        self.hours = tc.hours
        self.states = tc.get("aircraft_states")  # stop once this many aircraft-states were collected
        if self.max_iter is None and self.hours is None and self.states is None:
            self.max_iter = 100
        self.t_start = t_start
        self.stop_requested: str | None = None

    def may_start(self, done_iterations: int, collected: int) -> str | None:
        """None if iteration ``done_iterations + 1`` may start, else why the run stops."""
        if self.max_iter is not None and done_iterations >= int(self.max_iter):
            return "iterations"
        if self.states is not None and collected >= int(self.states):
            return "aircraft_states"
        if self.hours is not None and time.perf_counter() - self.t_start >= float(self.hours) * 3600.0:
            return "hours"
        return self.stop_requested  # after the budget's own reasons: a spent budget is a finished run


def checkpoint_meta(run: TrainingRun, behaviour: Any) -> dict[str, Any]:
    """A checkpoint's metadata; overlap: with the weights the next iteration is played with (exact resume)."""
    return {**run.meta, "behaviour_weights": behaviour} if run.overlap else run.meta


def record_iteration(run: TrainingRun, curve: CurveWriter, batches: list[EpisodeBatch], ep: dict[str, Any],
                     lstats: dict[str, Any], times: tuple[float, float, float], behaviour: Any) -> None:
    """After iteration ``run.state.iteration``'s update: its curve row, log line and checkpoints.

    ``times``: the clock when its episodes were submitted (or the previous update ended), when they
    came back and when the update ended [s]. ``best.pt`` when the rolling mean of the reward reaches
    a new maximum, ``last.pt`` every ``train.checkpoint_every`` iterations.
    """
    state, tc, it = run.state, run.cfg.train, run.state.iteration
    t0, t1, t2 = times
    row = {"iteration": it, "wall_s": _fmt(state.wall_s), "sim_s": _fmt(ep["sim_s"]),
           "episodes": len(batches), "reward_mean": _fmt(ep["reward_mean"]),
           "reward_std": _fmt(ep["reward_std"]),
           "episode_rewards": ";".join(_fmt(b.stats.reward_per_aircraft) for b in batches),
           **curve_row_values([b.stats for b in batches], run.columns, ep),
           "aircraft_states": ep["aircraft_states"], "aircraft_states_total": state.transitions,
           "states_per_s": _fmt(ep["aircraft_states"] / max(t2 - t0, 1e-9)), "rollout_s": _fmt(t1 - t0),
           "update_s": _fmt(t2 - t1)}
    row.update({k: _fmt(v) for k, v in lstats.items() if k in LEARNER_STATS})
    curve.write(row)
    window = int(tc.best_window)
    roll = float(rolling_mean(state.rewards, window)[-1])
    improved = len(state.rewards) >= window and roll > state.best
    if improved:
        state.best, state.best_iteration = roll, it
        save_checkpoint(run.ckpt_dir / "best.pt", run.learner, state, checkpoint_meta(run, behaviour))
    log.info("it %d | episodes %d | reward/ac %.4f%s | states %d | %.0f states/s"
             " | rollout %.1fs update %.1fs | rolling(%d) %.4f%s", it, state.episodes, ep["reward_mean"],
             _curve_text(ep, run.columns, " | "), ep["aircraft_states"],
             ep["aircraft_states"] / max(t2 - t0, 1e-9), t1 - t0, t2 - t1, window, roll,
             " *best*" if improved else "")
    if int(tc.checkpoint_every) > 0 and it % int(tc.checkpoint_every) == 0:
        save_checkpoint(run.ckpt_dir / "last.pt", run.learner, state, checkpoint_meta(run, behaviour))


def train_loop(run: TrainingRun, pool: Any, budget: Budget, curve: CurveWriter) -> str:
    """Play and learn until the budget says stop; returns why the run stopped.

    serial: the workers play iteration k with the learner's weights, then the learner updates.
    overlap: the workers play iteration k + 1 with the weights before update k while the learner
    updates (the episodes of iteration k come from the policy of update k - 2).
    """
    state, learner, cfg, overlap = run.state, run.learner, run.cfg, run.overlap
    slots, epw = max(run.n_workers, 1), int(cfg.train.episodes_per_worker)
    wall0 = state.wall_s
    t_train = time.perf_counter()  # throughput clock: iterations only (not Ray start-up nor baseline)

    def submit(it: int, weights: Any, collected: int, env_steps: int) -> Any:
        lists = [[episode_seed(int(cfg.seed), it, w, e) for e in range(epw)] for w in range(slots)]
        return pool.submit(lists, "policy", weights, learner.explore(collected, env_steps), lockstep=overlap)

    # overlap: the weights the in-flight iteration plays with (one update behind the learner's).
    behaviour = run.behaviour if run.behaviour is not None else learner.weights()
    stop = budget.may_start(state.iteration, state.transitions)
    pending = None if stop else submit(state.iteration + 1, behaviour, state.transitions, state.env_steps)
    t0 = time.perf_counter()
    while pending is not None:
        it = state.iteration + 1
        results = pool.wait(pending)
        batches: list[EpisodeBatch] = [b for part in results for b in part]
        t1 = time.perf_counter()
        ep = summarize_episodes([b.stats for b in batches], run.columns)
        pending = None
        if overlap:
            behaviour = learner.weights()
            stop = budget.may_start(it, state.transitions + ep["aircraft_states"])
            if not stop:
                pending = submit(it + 1, behaviour, state.transitions + ep["aircraft_states"],
                                 state.env_steps + ep["env_steps"])
        lstats = learner.update(batches)
        t2 = time.perf_counter()
        state.iteration = it
        state.transitions += ep["aircraft_states"]
        state.env_steps += ep["env_steps"]
        state.episodes += len(batches)
        state.wall_s = wall0 + (t2 - t_train)
        state.rollout_s += t1 - t0
        state.rewards.append(ep["reward_mean"])
        record_iteration(run, curve, batches, ep, lstats, (t0, t1, t2), behaviour)
        if not overlap:
            stop = budget.may_start(it, state.transitions)
            if not stop:
                pending = submit(it + 1, learner.weights(), state.transitions, state.env_steps)
        t0 = t2 if overlap else time.perf_counter()
    run.behaviour = behaviour
    return stop or "iterations"


def finish_training(run: TrainingRun, reason: str, elapsed: float) -> dict[str, Any]:
    """The final checkpoints (``best.pt`` too when the run was shorter than the rolling window) and
    ``training_summary.json``; returns the summary."""
    state, meta, tc, ckpt_dir = run.state, checkpoint_meta(run, run.behaviour), run.cfg.train, run.ckpt_dir
    save_checkpoint(ckpt_dir / "last.pt", run.learner, state, meta)
    if state.best_iteration == 0:
        # Fewer iterations than the rolling window: the final weights stand in for the best (also over a
        # stand-in that an earlier, shorter session of a resumed run wrote).
        state.best, state.best_iteration = float(rolling_mean(state.rewards, int(tc.best_window))[-1]) \
            if state.rewards else float("nan"), state.iteration
        save_checkpoint(ckpt_dir / "best.pt", run.learner, state, meta)
    summary: dict[str, Any] = {
               "algorithm": str(run.cfg.algorithm.name), "label": meta["algorithm"]["label"],
               "scenario": Path(run.env.scenario).stem,
               "workers": run.n_workers, "iterations": state.iteration, "episodes": state.episodes,
               "aircraft_states": state.transitions, "env_steps": state.env_steps, "wall_s": state.wall_s,
               "states_per_s": state.transitions / state.wall_s if state.wall_s > 0 else None,
               "states_per_hour": 3600.0 * state.transitions / state.wall_s if state.wall_s > 0 else None,
               "rollout_s": state.rollout_s,
               "rollout_states_per_s": state.transitions / state.rollout_s if state.rollout_s > 0 else None,
               "this_session_s": elapsed, "stopped_by": reason, "best_rolling_reward": state.best,
               "best_iteration": state.best_iteration, "best_window": int(tc.best_window), "device": run.device,
               "code": meta["code"]}
    (run.run_dir / "training_summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    log.info("done: %d iterations, %d aircraft-states in %.0f s (%.0f states/s); best rolling reward %.4f at "
             "iteration %d", state.iteration, state.transitions, state.wall_s, summary["states_per_s"] or 0.0,
             state.best, state.best_iteration)
    return summary


def run_training(cfg: DictConfig, run_dir: str | Path) -> dict[str, Any]:
    """Train ``cfg.algorithm`` on ``cfg.scenario``; everything goes to ``run_dir``.

    The steps: :func:`build_training` (learner, resume), :func:`play_baseline`, :func:`train_loop`
    (each iteration recorded by :func:`record_iteration`), :func:`finish_training`.
    """
    run = build_training(cfg, run_dir)
    curve = CurveWriter(run.run_dir / "learning_curve.csv", curve_columns(run.columns))
    actors = {"policy": run.learner.actor_spec(str(cfg.algorithm.kind)), "unequipped": {"kind": "unequipped"}}
    log.info("training %s on %s with %s, device %s; output in %s", cfg.algorithm.name, Path(run.env.scenario).name,
             f"{run.n_workers} Ray workers" if run.n_workers else "an in-process worker", run.device, run.run_dir)
    pool = make_pool(run.n_workers, run.env, actors, cfg.ray, 1)  # one PyTorch thread per worker (one CPU each)
    t_start = time.perf_counter()
    budget = Budget(cfg.train, t_start)

    def stop_at_iteration_boundary(signum: int, frame: Any) -> None:
        budget.stop_requested = signal.Signals(signum).name
        log.warning("%s: stopping once the iterations already started are learned from (a checkpoint then); "
                    "again: stop at once", budget.stop_requested)
        stops.replace(signal.default_int_handler)

    stops = StopSignals(stop_at_iteration_boundary)  # bound before a signal can call the handler
    with stops:
        try:
            play_baseline(run, pool)
            reason = train_loop(run, pool, budget, curve)
        finally:
            pool.shutdown()
    if budget.stop_requested is not None and reason == budget.stop_requested:
        stop_training(run)
        raise TrainingStopped(run.run_dir, run.state.iteration, reason)
    return finish_training(run, reason, time.perf_counter() - t_start)


def stop_training(run: TrainingRun) -> None:
    """``last.pt`` at the iteration a stop signal ended the run on: what a periodic checkpoint there holds
    (overlap: the weights the next iteration is to be played with), so that resuming is exact."""
    save_checkpoint(run.ckpt_dir / "last.pt", run.learner, run.state, checkpoint_meta(run, run.behaviour))
    log.warning("stopped after iteration %d: %s written, no training_summary.json (not finished); "
                "continue with train.resume=%s", run.state.iteration, run.ckpt_dir / "last.pt", run.run_dir)


def hydra_entry() -> None:
    """The Hydra app (``aamgym train ...``): composes the config and calls :func:`run_training`."""
    import hydra
    from hydra.core.hydra_config import HydraConfig

    from rlbridge.experiment.configstore import register_configs

    register_configs()

    @hydra.main(config_path="../conf", config_name="config", version_base="1.3")
    def _main(cfg: DictConfig) -> None:
        run_training(cfg, HydraConfig.get().runtime.output_dir)

    try:
        _main()
    except TrainingStopped:
        raise SystemExit(130) from None  # 128 + SIGINT, as a shell reports Ctrl-C; the log said where it stands
