"""``aamgym study``: the paper's whole study (Tables II/III, learning curves) in one command.

    aamgym study                               # the full study (days on a small machine: see --plan)
    aamgym study --smoke                       # the same pipeline, tiny: about 30 min on 2 cores
    aamgym study --plan                        # print what would run and the time it would take
    scripts/reproduce_paper.sh [same options]  # the same command

For every use-case configuration (the paper's ``corridor_sa`` and the corrected
``corridor_sa_v1``; their tables are kept apart), every contender (D2MAV-A No Shared Layers,
D2MAV-A Shared Layers, DDQN; the paper's hyper-parameters, ``rlbridge/conf/algorithm``) and
every seed, it trains on the training scenario until the same budget of aircraft-states
(``--budget``, 15 M by default), keeps the best weights by the 25-iteration rolling mean
(``train.best_window``, the paper's), and evaluates them for 100 seeds on each evaluation
scenario, greedy and with sampled actions, against the unequipped aircraft and the baselines
(``--baselines``: ``mvp_speed`` and any other registered baseline, e.g. ``daa`` once it
exists). Then ``aamgym report`` writes the tables and the learning curves (95 % bands across
seeds) to ``--out`` (``docs/results/study``), with the resolved configuration of every run,
the paper's published numbers (labelled as the paper's) and the study's plan.

Finished runs are kept under ``--work`` and skipped when the study is started again, so an
interrupted study resumes where it stopped. The study also resumes on another machine, or after
the work directory is gone, from what is committed under ``--out``: a run exported to
``runs/`` is finished (its evaluations load the exported weights), an evaluation exported to
``evaluations/`` is done, and a run parked by ``--park`` in ``in_progress/`` (its last and best
checkpoints, curve and configuration) continues from its last checkpoint. Nothing under
``--out`` names a path of the machine (paths are written relative to ``--work``).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

log = logging.getLogger("aamgym.study")

CONTENDERS = ("d2mava_a", "d2mava_a_shared", "ddqn")
USECASES = ("corridor_sa", "corridor_sa_v1")
# The paper's Tables II and III (risk and LoWC ratios, mean ± std over 100 evaluation episodes;
# 100 training hours with 40 workers). Quoted, never measured here.
PAPER_TABLES = {
    "risk_ratio": {"D2MAV-A No Shared Layers": ("0.0107 ± 0.0343", "0.4875 ± 0.0303"),
                   "D2MAV-A Shared Layers": ("0.2443 ± 0.146", "0.5926 ± 0.0648"),
                   "DDQN": ("0.4706 ± 0.0", "0.5694 ± 0.0")},
    "lowc_ratio": {"D2MAV-A No Shared Layers": ("0.5009 ± 0.0083", "0.7159 ± 0.0112"),
                   "D2MAV-A Shared Layers": ("0.6722 ± 0.0807", "0.7808 ± 0.0266"),
                   "DDQN": ("0.6667 ± 0.0", "0.8654 ± 0.0")},
}
# Aircraft-states per second after the first iteration on the 2-core development machine with
# train.mode=overlap and one worker, load average 2-4 (bench/bench_train.py, docs/algorithms.md
# "Learning throughput"): the plan's time estimate. Pass --rates to use a machine's own figures.
# DDQN with RLlib's update ratio (one gradient step per 160 environment steps) is bound by its
# rollouts: measured 1,065 at load 13-15 in the same invocation as D2MAV-A's 413
# (`bench/bench_train.py --against 5349319 --paths new --algorithms ddqn d2mava_a --iterations 6`),
# scaled by D2MAV-A's 5,678 / 413 to the load of the other figures: 14,600.
DEFAULT_RATES = {"d2mava_a": 5678.0, "d2mava_a_shared": 5691.0, "ddqn": 14600.0}


@dataclass
class StudyPlan:
    """What the study runs (every field is a command-line option)."""

    contenders: list[str] = field(default_factory=lambda: list(CONTENDERS))
    usecases: list[str] = field(default_factory=lambda: list(USECASES))
    seeds: list[int] = field(default_factory=lambda: [0, 1])
    budget: int = 15_000_000  # aircraft-states per training run
    train_scenario: str = "nyc_train_100"
    eval_scenarios: list[str] = field(default_factory=lambda: ["nyc_train_100", "nyc_eval_678"])
    episodes: int = 100  # evaluation episodes per policy and scenario
    baselines: list[str] = field(default_factory=lambda: ["mvp_speed", "daa"])  # the issue: MVP and DAA beside unequipped
    actions: list[str] = field(default_factory=lambda: ["greedy", "sampled"])
    workers: int | str = 1  # or "auto": the cores the learner leaves (train.resolve_workers)
    mode: str = "overlap"
    best_window: int = 25
    smooth: int = 25  # rolling mean of the report's curves [iterations]
    overrides: list[str] = field(default_factory=list)  # more Hydra overrides for every training run
    smoke: bool = False

    def runs(self) -> list[tuple[str, str, int]]:
        return [(uc, algo, seed) for uc in self.usecases for algo in self.contenders for seed in self.seeds]


def smoke_plan(plan: StudyPlan) -> StudyPlan:
    """The same pipeline, tiny: a few thousand aircraft-states per run, two evaluation episodes."""
    plan.budget = min(plan.budget, 2_000)
    plan.episodes = min(plan.episodes, 2)
    plan.best_window = 2
    plan.smooth = 1
    plan.smoke = True
    return plan


def estimate_hours(plan: StudyPlan, rates: dict[str, float]) -> dict[str, float]:
    """Training wall-clock hours per contender (one run) and in all, from aircraft-states per second."""
    per_run = {a: plan.budget / rates[a] / 3600.0 for a in plan.contenders}
    total = sum(per_run[a] for _, a, _ in plan.runs())
    return {**{f"{a} per run": h for a, h in per_run.items()}, "all training runs": total}


def _compose(name: str, overrides: list[str]) -> Any:
    from rlbridge.experiment.configstore import compose_config

    return compose_config(name, overrides)


def train_overrides(plan: StudyPlan, usecase: str, algo: str, seed: int) -> list[str]:
    over = [f"algorithm={algo}", f"usecase={usecase}", f"scenario={plan.train_scenario}", f"seed={seed}",
            f"workers={plan.workers}", f"train.mode={plan.mode}", f"train.aircraft_states={plan.budget}",
            f"train.best_window={plan.best_window}", "train.torch_threads=auto",
            "device=auto"]  # the learner on a GPU when there is one
    if plan.smoke:
        over += ["train.baseline_episodes=1", "train.checkpoint_every=0"]
    return over + list(plan.overrides)


def evaluation_workers(plan: StudyPlan) -> int:
    """The rollout workers of the study's evaluations: ``--workers``; ``auto`` leaves the driver one core
    (an evaluation has no learner)."""
    return int(plan.workers) if str(plan.workers) != "auto" else max(1, (os.cpu_count() or 2) - 1)


def start_ray(plan: StudyPlan) -> None:
    """One Ray for the whole study's evaluations (each pool then finds it running instead of starting its own)."""
    workers = evaluation_workers(plan)
    if workers <= 0:
        return
    import ray

    if not ray.is_initialized():
        from rlbridge.experiment.workers import _code_root

        paths = [_code_root()] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
        os.environ.setdefault("RAY_worker_niceness", "0")
        ray.init(num_cpus=max(os.cpu_count() or 1, workers), include_dashboard=False, log_to_driver=True,
                 runtime_env={"env_vars": {"PYTHONPATH": os.pathsep.join(dict.fromkeys(paths))}})


def sampled_label(label: str, algo: str) -> str:
    """The label of a policy's non-greedy evaluation: what "sampled" means for it."""
    kind = str(_compose("config", [f"algorithm={algo}"]).algorithm.kind)
    return f"{label}, epsilon-greedy 0.05" if kind == "dqn" else f"{label}, sampled actions"


def eval_overrides(plan: StudyPlan, run: Path, scenario: str, actions: str, label: str, algo: str = "d2mava_a"
                   ) -> list[str]:
    greedy = actions == "greedy"
    # Baselines once per seed set (with the greedy evaluation); unequipped always (the ratios' reference).
    baselines = plan.baselines if greedy else []
    name = label if greedy else sampled_label(label, algo)
    # A run of this work directory has its checkpoints; a committed export (:func:`export_run`) has the
    # best weights as plain data, which `aamgym evaluate policy=<folder>` loads.
    source = f"run={run}" if (run / "checkpoints").is_dir() else f"policy={run}"
    return [source, f"scenario={scenario}", f"episodes={plan.episodes}", f"workers={evaluation_workers(plan)}",
            f"greedy={str(greedy).lower()}", f"baselines=[{','.join(baselines)}]", f"name='{name}'"]


STAGES = ("train", "evaluate", "report")


def run_study(plan: StudyPlan, work: Path, out: Path, stages: tuple[str, ...] = STAGES) -> dict[str, Any]:
    """Train, evaluate, report (see the module docstring); returns the study's index.

    ``stages`` picks what runs: ``train`` trains the runs not finished yet (a run interrupted in
    the middle continues from its last checkpoint); ``evaluate`` evaluates the finished runs; every
    finished run is exported to ``out/runs`` (config, curve, summary, best policy as plain data) so
    it can be committed as soon as it finishes; ``report`` writes the tables and curves.
    """
    from rlbridge.experiment.evaluate import run_evaluation
    from rlbridge.experiment.report import make_report
    from rlbridge.experiment.train import run_training

    unknown = [s for s in stages if s not in STAGES]
    if unknown:
        raise ValueError(f"unknown stage(s) {', '.join(unknown)}; known: {', '.join(STAGES)}")
    work.mkdir(parents=True, exist_ok=True)
    train_dirs: list[Path] = []
    eval_dirs: list[Path] = []
    run_ids: list[str] = []  # train/<use case>/<run>, eval/<use case>/<run>/<scenario>_<actions>
    eval_ids: list[str] = []
    t0 = time.perf_counter()
    for uc, algo, seed in plan.runs():
        run_id = f"{uc}/{algo}_s{seed}"
        run = work / "train" / run_id
        exported = out / "runs" / run_id
        overrides = train_overrides(plan, uc, algo, seed)
        cfg = _compose("config", overrides)
        finished = (run / "training_summary.json").exists()
        # A run trained on another machine (or in an earlier session whose work directory is gone)
        # counts as finished when its export is there: weights, summary, curve, configuration.
        committed = not finished and is_exported_run(exported)
        if "train" in stages and not finished and not committed:
            if not (run / "checkpoints" / "last.pt").exists() and restore_parked_run(out / PARKED / run_id, run):
                log.info("restored %s from %s (parked at the end of an earlier session)", run_id, out / PARKED)
            if (run / "checkpoints" / "last.pt").exists():
                log.info("continuing %s on %s (%s), seed %d from its last checkpoint", algo, plan.train_scenario,
                         uc, seed)
                cfg = _compose("config", overrides + [f"train.resume={run.resolve()}"])
            else:
                log.info("training %s on %s (%s), seed %d: %d aircraft-states", algo, plan.train_scenario, uc,
                         seed, plan.budget)
            run_training(cfg, run)
            finished = True
        if finished:
            export_run(work, run, exported)
            drop_parked(out / PARKED / run_id)
        elif not committed:
            continue
        train_dirs.append(run if finished else exported)
        run_ids.append(f"train/{run_id}")
        label = str(cfg.algorithm.label)
        for scen in plan.eval_scenarios:
            for actions in plan.actions:
                ev_id = evaluation_id(run_id, scen, actions)
                ev, ev_out = work / "eval" / ev_id, out / "evaluations" / ev_id
                done_here = (ev / "evaluation.json").exists()
                if "evaluate" in stages and not done_here and not (ev_out / "evaluation.json").exists():
                    log.info("evaluating %s seed %d on %s (%s actions)", algo, seed, scen, actions)
                    start_ray(plan)
                    policy = run if finished else exported
                    run_evaluation(_compose("evaluate", eval_overrides(plan, policy, scen, actions, label, algo)), ev,
                                   # "baselines": the name from when only baselines' episodes were kept
                                   # (a study's work folder keeps its cache); the policies' are there too
                                   episode_cache=work / "baselines")
                    done_here = True
                if done_here:
                    export_evaluation(work, ev, ev_out)
                    eval_dirs.append(ev)
                elif (ev_out / "evaluation.json").exists():
                    eval_dirs.append(ev_out)  # evaluated in an earlier session: its committed files
                else:
                    continue
                eval_ids.append(f"eval/{ev_id}")
    out.mkdir(parents=True, exist_ok=True)
    if "report" in stages and eval_dirs:
        make_report(eval_dirs, train_dirs, out, plan.smooth, departures(plan))
        copy_configs(work, train_dirs + eval_dirs, out / "configs", run_ids + eval_ids)
        (out / "paper.md").write_text(paper_tables_md())
    index = {"plan": asdict(plan), "training_runs": run_ids, "evaluations": eval_ids,
             "runs_planned": len(plan.runs()),
             "evaluations_planned": len(plan.runs()) * len(plan.eval_scenarios) * len(plan.actions),
             "wall_s_this_session": time.perf_counter() - t0}
    (out / "study.json").write_text(json.dumps(index, indent=2) + "\n")
    return index


def export_run(work: Path, run: Path, dest: Path) -> None:
    """A finished training run as files to commit: its configuration (no machine paths), learning curve,
    unequipped reference, summary and best policy (plain data, :mod:`rlbridge.experiment.export`)."""
    import shutil

    from rlbridge.experiment.export import export_policy

    if (dest / "policy.npz").exists() and (dest / "training_summary.json").exists():
        return
    dest.mkdir(parents=True, exist_ok=True)
    for name in ("learning_curve.csv", "baseline.json", "training_summary.json"):
        if (run / name).exists():
            shutil.copy(run / name, dest / name)
    copy_configs(work, [run], dest.parent / ".configs")
    shutil.move(str(dest.parent / ".configs" / run.relative_to(work) / "resolved_config.yaml"),
                dest / "resolved_config.yaml")
    shutil.rmtree(dest.parent / ".configs")
    export_policy(run / "checkpoints" / "best.pt", dest)


def export_evaluation(work: Path, ev: Path, dest: Path) -> None:
    """A finished evaluation as files to commit: its summary (``evaluation.json``), its episode tables
    (``episodes.csv`` and ``episode_metrics.csv``, every policy's episodes on the same seeds) and its
    configuration, with the machine's paths written relative to the study. The per-episode folders
    (logs, trajectories) stay in the work directory: the report reads only these files."""
    if (dest / "evaluation.json").exists():
        return
    dest.mkdir(parents=True, exist_ok=True)
    for name in ("episodes.csv", "episode_metrics.csv", "resolved_config.yaml",
                 "evaluation.json"):  # evaluation.json last: the marker
        if (ev / name).exists():
            (dest / name).write_text(relative_to_study(work, (ev / name).read_text()))


# Where the unfinished training runs are parked for committing at the end of a working session
# (``--park``), under ``--out``: the next session, on whatever machine, continues them from there.
PARKED = "in_progress"
_PARKED_FILES = ("resolved_config.yaml", "learning_curve.csv", "baseline.json")
_PARKED_CHECKPOINTS = ("last.pt", "best.pt")


def is_exported_run(d: Path) -> bool:
    """A finished run's export (:func:`export_run`): what evaluating and reporting it needs."""
    return all((d / name).is_file() for name in ("training_summary.json", "policy.npz", "policy.json",
                                                  "learning_curve.csv", "resolved_config.yaml"))


def _map_strings(x: Any, text: Any) -> Any:
    if isinstance(x, dict):
        return {k: _map_strings(v, text) for k, v in x.items()}
    if isinstance(x, list):
        return [_map_strings(v, text) for v in x]
    if isinstance(x, tuple):
        return tuple(_map_strings(v, text) for v in x)
    return text(x) if isinstance(x, str) else x


def _rewrite_checkpoint(src: Path, dst: Path, run_dir: str, scenario: str, text: Any = None) -> None:
    """``src`` saved as ``dst`` with its machine-specific fields replaced (the run directory, the training
    scenario's path, and every other string through ``text``); weights, optimiser, counters and RNG state
    the same."""
    import torch

    from rlbridge.experiment.train import load_checkpoint

    ckpt = load_checkpoint(src)
    if text is not None:
        ckpt = _map_strings(ckpt, text)
    ckpt["run_dir"] = run_dir
    ckpt["env"] = {**ckpt["env"], "scenario": scenario}
    tmp = dst.with_suffix(".tmp")
    torch.save(ckpt, tmp)
    tmp.replace(dst)


def _portable_scenario(work: Path, path: str) -> str:
    """A scenario as a name when it is a shipped one (the same file as the one found by that name, which
    any machine finds), else relative to the study (:func:`relative_to_study`: found again when the study
    runs from the same folder)."""
    from aamsim.scenarios import resolve_scenario

    name = Path(path).stem
    found = resolve_scenario(name)
    if found is not None and Path(path).is_file() and Path(found).read_bytes() == Path(path).read_bytes():
        return name  # the shipped file, here or in another checkout (a study run from a worktree)
    return relative_to_study(work, path)


def park_run(work: Path, run: Path, dest: Path) -> bool:
    """Copy an unfinished run's state (its last and best checkpoints, curve, baseline, configuration) to
    ``dest`` for committing, with no path of this machine in it; False when it has no checkpoint yet."""
    from rlbridge.experiment.train import load_checkpoint

    last = run / "checkpoints" / "last.pt"
    if not last.exists() or (run / "training_summary.json").exists():
        return False
    import shutil

    tmp = dest.with_name(dest.name + ".parking")
    shutil.rmtree(tmp, ignore_errors=True)
    (tmp / "checkpoints").mkdir(parents=True)
    run_id = str(run.relative_to(work))
    for name in _PARKED_CHECKPOINTS:  # last.pt first: a best.pt written meanwhile is newer, never older
        if (run / "checkpoints" / name).exists():
            scenario = _portable_scenario(work, str(load_checkpoint(run / "checkpoints" / name)["env"]["scenario"]))
            _rewrite_checkpoint(run / "checkpoints" / name, tmp / "checkpoints" / name, run_id, scenario,
                                lambda t: relative_to_study(work, t))
    for name in _PARKED_FILES:
        if (run / name).exists():
            (tmp / name).write_text(relative_to_study(work, (run / name).read_text()))
    shutil.rmtree(dest, ignore_errors=True)
    tmp.replace(dest)
    return True


def restore_parked_run(parked: Path, run: Path) -> bool:
    """A parked run (:func:`park_run`) copied into the work directory ``run``, its checkpoints naming this
    machine's paths again, so that training continues in place from its last checkpoint."""
    if not (parked / "checkpoints" / "last.pt").is_file():
        return False
    from rlbridge.experiment.train import load_checkpoint, resolve_scenario_path

    (run / "checkpoints").mkdir(parents=True, exist_ok=True)
    for name in _PARKED_FILES:
        if (parked / name).exists():
            (run / name).write_text((parked / name).read_text())
    for name in ("best.pt", "last.pt"):  # last.pt last: its presence marks a run that can continue
        if (parked / "checkpoints" / name).exists():
            scenario = resolve_scenario_path(str(load_checkpoint(parked / "checkpoints" / name)["env"]["scenario"]))
            _rewrite_checkpoint(parked / "checkpoints" / name, run / "checkpoints" / name, str(run.resolve()),
                                scenario)
    return True


def drop_parked(parked: Path) -> None:
    """The parked copy of a run that has finished (its export replaces it)."""
    import shutil

    if parked.is_dir():
        shutil.rmtree(parked)
        if parked.parent.is_dir() and not any(parked.parent.iterdir()):
            parked.parent.rmdir()


def park_study(plan: StudyPlan, work: Path, out: Path) -> list[str]:
    """``--park``: every unfinished run of ``plan`` with a checkpoint in ``work`` parked under ``out``."""
    parked = []
    for uc, algo, seed in plan.runs():
        run_id = f"{uc}/{algo}_s{seed}"
        if park_run(work, work / "train" / run_id, out / PARKED / run_id):
            parked.append(run_id)
    return parked


def relative_to_study(work: Path, text: str) -> str:
    """``text`` with this machine's paths (the study's work directory, the current directory, the home)
    written relative to the study, so that committed files name no path of the machine they were made on."""
    import os

    roots = sorted({str(work.resolve()), str(work), str(Path.cwd().resolve()), os.path.expanduser("~")},
                   key=len, reverse=True)
    for root in roots:
        text = text.replace(root + os.sep, "").replace(root, ".")
    return text


def departures(plan: StudyPlan) -> list[str]:
    """What this study does differently from the paper (named under every table that shows its results)."""
    if str(plan.workers) == "auto":
        workers = "workers=auto (the cores the learner leaves: 15 on a 16-core machine with a GPU)"
        per_update = "that many"
    else:
        workers = f"{max(int(plan.workers), 1)} rollout worker(s)"
        per_update = str(max(int(plan.workers), 1))
    out = [(f"training budget: {plan.budget:,} aircraft-states per run, the same for every contender (the paper: "
           "100 h on 40 workers; 342 M aircraft-states for D2MAV-A No Shared Layers)"),
           (f"{workers}, one episode per iteration (the paper: 40 workers, one episode each per iteration), so "
           f"each update learns from {per_update} episode(s) and the best weights are chosen by the "
           f"{plan.best_window}-iteration rolling mean over that many episodes"),
           ("altitude noise drawn per episode seed (uniform ±100 ft about the lanes, the paper's distribution), in "
           "training and evaluation (the paper: the scenario's single draw)"),
           ("DDQN is updated as RLlib's DQN updated the paper's run (one gradient step of 512 per 160 environment "
           "steps; learning_starts 1,000 environment steps, RLlib's default: not in the paper); DDQN's 'sampled' "
           "evaluation is epsilon-greedy with epsilon 0.05 (Mnih et al. 2015), not in the paper"),
           ("hyper-parameters the paper does not give: D2MAV-A value coefficient 0.5, gradient clip 0.5 (actor and "
           "critic apart), per-minibatch advantage normalisation; a decision every 10 s; intruders within 10 km")]
    if plan.mode == "overlap":
        out.append("train.mode=overlap: the workers play iteration k+1 while the learner updates on iteration k "
                   "(the episodes of an iteration come from the weights one update older than the paper's loop)")
    if "corridor_sa_v1" in plan.usecases:
        out.append("the _v1 tables: use case variant v1, the paper's reward plus a hover cost (not the paper's)")
    return out


def copy_configs(work: Path, dirs: list[Path], dest: Path, ids: list[str] | None = None) -> None:
    """Each run's resolved configuration, with the machine's paths written relative to the study, under
    ``dest/<id>`` (``ids``: one per directory; by default its path relative to ``work``)."""
    for d, name in zip(dirs, ids or [str(d.relative_to(work)) for d in dirs]):
        target = dest / name / "resolved_config.yaml"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(relative_to_study(work, (d / "resolved_config.yaml").read_text()))


def paper_tables_md() -> str:
    lines = ["# The paper's published numbers (quoted, not measured here)", "",
             ("Brittain, Alvarez et al., *AAM-Gym: Artificial Intelligence Testbed for Advanced Air Mobility*, "
              "Tables II and III: mean ± std over 100 evaluation episodes, after 100 training hours with 40 "
              "workers; 100 = the training scenario (100 aircraft, 25 min), 678 = the evaluation scenario "
              "(678 aircraft, 5 h). The tables beside this file are this repository's measurements; compare "
              "them with these, never pool them."), ""]
    for name, title in (("risk_ratio", "Risk ratio"), ("lowc_ratio", "LoWC ratio")):
        lines += [f"### The paper's {title.lower()} (Table {'II' if name == 'risk_ratio' else 'III'})", "",
                  f"| Algorithm | {title} - 100 (paper) | {title} - 678 (paper) |", "|---|---|---|"]
        lines += [f"| {a} | {v[0]} | {v[1]} |" for a, v in PAPER_TABLES[name].items()]
        lines.append("")
    return "\n".join(lines)


def _workers(text: str) -> int | str:
    return "auto" if text == "auto" else int(text)


def machine_line(plan: StudyPlan, device: str, workers: int, rates: dict[str, float]) -> str:
    """The estimate for this machine (:mod:`rlbridge.experiment.machine`), as --plan prints it."""
    from rlbridge.experiment.machine import machine_estimate

    kinds = {a: str(_compose("config", [f"algorithm={a}"]).algorithm.kind) for a in plan.contenders}
    m = machine_estimate(kinds, device, workers, rates)
    hours = {a: plan.budget / m.rates[a] / 3600.0 for a in plan.contenders}
    total = sum(hours[a] for _, a, _ in plan.runs())
    gpu = " (a GPU learner: its rate alone as measured on an H200)" if device.startswith("cuda") else \
        " (a CPU learner: at least the rates above)"
    return (f"this machine: {m.cores} CPUs, learner on {device}, {m.workers} worker(s){gpu}: "
            + ", ".join(f"{a} {hours[a]:.2f} h per run ({m.rates[a]:,.0f} aircraft-states/s: {m.bound[a]})"
                        for a in plan.contenders) + f", all training runs {total:.1f} h")


def measured_line(plan: StudyPlan, out: Path) -> str | None:
    """What the committed runs (``out/runs/*/*/training_summary.json``) took, per contender, and what the
    runs not finished yet would take at those rates: the estimate from this study's own wall clock
    (slices share the machine with other runs and evaluations, so it is slower than the benchmarks)."""
    done: dict[str, list[tuple[float, float]]] = {}
    for f in sorted(out.glob("runs/*/*/training_summary.json")):
        s = json.loads(f.read_text())
        if s.get("wall_s") and s.get("aircraft_states"):
            done.setdefault(str(s["algorithm"]), []).append((float(s["aircraft_states"]), float(s["wall_s"])))
    if not done:
        return None
    rates = {a: sum(n for n, _ in v) / sum(t for _, t in v) for a, v in done.items()}
    left = [(uc, a, seed) for uc, a, seed in plan.runs() if not is_exported_run(out / "runs" / uc / f"{a}_s{seed}")]
    hours = sum(plan.budget / rates[a] / 3600.0 for _, a, _ in left if a in rates)
    unmeasured = sorted({a for _, a, _ in left if a not in rates})
    parts = [f"{a} {len(v)} run{'s' * (len(v) != 1)}, {rates[a]:,.0f} aircraft-states/s, "
             f"{plan.budget / rates[a] / 3600.0:.1f} h per run" for a, v in sorted(done.items())]
    text = (f"measured in the committed runs ({out / 'runs'}, wall clock of their slices): " + "; ".join(parts)
            + (f"; the {len(left)} run{'s' * (len(left) != 1)} not finished: {hours:.1f} h" if left
               else "; every run finished"))
    if unmeasured:
        text += f" plus those of {', '.join(unmeasured)} (no run of it finished yet)"
    return text


def evaluation_id(run_id: str, scenario: str, actions: str) -> str:
    """``<use case>/<run>/<traffic>_<actions>``: an evaluation's folder under ``eval/`` and ``evaluations/``."""
    return f"{run_id}/{Path(scenario).stem}_{actions}"


def evaluation_traffic(ev_id: str) -> str:
    """The traffic (scenario stem) of an evaluation id."""
    return ev_id.rsplit("/", 1)[-1].rsplit("_", 1)[0]


def measured_evaluations_line(plan: StudyPlan, out: Path) -> str | None:
    """What the committed evaluations (``out/evaluations/<use case>/<run>/<traffic>_<actions>/``) took per
    traffic, and what the evaluations left would take at that pace: the policy's episodes (median time
    per episode over the committed evaluations of that traffic) and, where their episodes are not cached
    yet, the baselines' (played once per use-case configuration and traffic)."""
    import statistics

    policy: dict[str, list[float]] = {}
    baselines: dict[str, list[float]] = {}
    done: set[str] = set()
    for f in sorted(out.glob("evaluations/*/*/*/evaluation.json")):
        ev = json.loads(f.read_text())
        ev_id = str(f.parent.relative_to(out / "evaluations"))
        done.add(ev_id)
        traffic, n = evaluation_traffic(ev_id), max(int(ev.get("episodes") or 1), 1)
        pols = ev.get("policies", {})
        policy.setdefault(traffic, []).extend(p["wall_s"] / n for p in pols.values() if p.get("learned"))
        if len(pols) > 2:  # an evaluation that played every baseline (greedy), not only the unequipped
            baselines.setdefault(traffic, []).append(sum(p["wall_s"] for p in pols.values() if not p.get("learned")) / n)
    if not done:
        return None
    planned = [evaluation_id(f"{uc}/{a}_s{seed}", scen, actions) for uc, a, seed in plan.runs()
               for scen in plan.eval_scenarios for actions in plan.actions]
    left = [e for e in planned if e not in done]
    per = {t: statistics.median(v) * plan.episodes / 3600.0 for t, v in policy.items() if v}
    hours = sum(per.get(evaluation_traffic(e), 0.0) for e in left)
    unmeasured = sorted({evaluation_traffic(e) for e in left} - set(per))
    parts = [f"{t} {per[t] * 60:.0f} min for the policy's {plan.episodes} episodes"
             + (f", {statistics.median(baselines[t]) * plan.episodes / 60:.0f} min for the baselines'"
                if baselines.get(t) else "") for t in sorted(per)]
    text = (f"measured in the committed evaluations ({len(done)} of {len(planned)}, their episodes' time): "
            + "; ".join(parts) + (f"; the {len(left)} evaluation{'s' * (len(left) != 1)} left: {hours:.1f} h, "
                                  "plus the baselines' where their episodes are not cached yet" if left
                                  else "; every evaluation done"))
    if unmeasured:
        text += f" and those on {', '.join(unmeasured)} (no evaluation of it committed yet)"
    return text


def main(argv: list[str] | None = None) -> None:
    plan = StudyPlan()
    ap = argparse.ArgumentParser(prog="aamgym study", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--smoke", action="store_true",
                    help="the whole pipeline, tiny runs and 2 episodes per evaluation (about 30 min on 2 cores)")
    ap.add_argument("--plan", action="store_true", help="print the plan and its time estimate, run nothing")
    ap.add_argument("--work", type=Path, default=Path("runs/study"), help="run directories (default runs/study)")
    ap.add_argument("--out", type=Path, default=None,
                    help="the report (default docs/results/study; with --smoke WORK/report)")
    ap.add_argument("--contenders", nargs="+", default=plan.contenders)
    ap.add_argument("--usecases", nargs="+", default=plan.usecases,
                    help="use-case configurations (rlbridge/conf/usecase)")
    ap.add_argument("--seeds", nargs="+", type=int, default=plan.seeds)
    ap.add_argument("--budget", type=int, default=plan.budget, help="aircraft-states per training run")
    ap.add_argument("--train-scenario", default=plan.train_scenario)
    ap.add_argument("--eval-scenarios", nargs="+", default=plan.eval_scenarios)
    ap.add_argument("--episodes", type=int, default=plan.episodes, help="evaluation episodes per policy")
    ap.add_argument("--baselines", nargs="*", default=plan.baselines,
                    help="baselines beside unequipped (mvp_speed, daa, ...)")
    ap.add_argument("--workers", type=_workers, default=plan.workers,
                    help="Ray workers per run (stated in the report); auto: the cores the learner leaves")
    ap.add_argument("--mode", default=plan.mode, choices=("serial", "overlap"), help="train.mode")
    ap.add_argument("--rates", type=json.loads, default=None,
                    help='aircraft-states/s per contender for the estimate, e.g. \'{"ddqn": 900}\'')
    ap.add_argument("--stages", nargs="+", default=list(STAGES), choices=STAGES,
                    help="what runs: train (unfinished runs, continuing interrupted ones), evaluate, report; "
                         "finished runs are exported to OUT/runs in every case")
    ap.add_argument("--park", action="store_true",
                    help=f"copy the unfinished runs' last checkpoints to OUT/{PARKED} (no machine paths) for "
                         "committing, then exit: the next start, on any machine, continues them from there")
    ap.add_argument("overrides", nargs="*", help="more Hydra overrides for every training run")
    args = ap.parse_args(argv)
    plan = StudyPlan(contenders=args.contenders, usecases=args.usecases, seeds=args.seeds, budget=args.budget,
                     train_scenario=args.train_scenario, eval_scenarios=args.eval_scenarios,
                     episodes=args.episodes, baselines=args.baselines, workers=args.workers, mode=args.mode,
                     overrides=list(args.overrides))
    if args.smoke:
        plan = smoke_plan(plan)
    out = args.out or (args.work / "report" if args.smoke else Path("docs/results/study"))
    from rlbridge.experiment.train import resolve_device, resolve_workers

    try:  # the learner's device, checked before anything starts (the runs take device=auto unless told)
        device = resolve_device(next((o.split("=", 1)[1] for o in reversed(plan.overrides)
                                      if o.startswith("device=")), "auto"))
        workers = resolve_workers(plan.workers, device)
    except ValueError as exc:
        ap.error(str(exc))
    rates = {**DEFAULT_RATES, **(args.rates or {})}
    est = estimate_hours(plan, rates)
    print(f"{len(plan.runs())} training runs of {plan.budget:,} aircraft-states "
          f"({', '.join(plan.contenders)} x {', '.join(plan.usecases)} x seeds {plan.seeds}), "
          f"{len(plan.runs()) * len(plan.eval_scenarios) * len(plan.actions)} evaluations of {plan.episodes} episodes")
    print("estimated training time (rates measured on the 2-core development machine, overlap, 1 worker"
          + (", or --rates" if args.rates else "") + "): " + ", ".join(f"{k} {v:.1f} h" for k, v in est.items()))
    print(machine_line(plan, device, workers, rates))
    for measured in (measured_line(plan, out), measured_evaluations_line(plan, out)):
        if measured:
            print(measured)
    if args.plan:
        return
    if args.park:
        for run_id in park_study(plan, args.work, out):
            print(f"parked {run_id} in {out / PARKED / run_id}")
        return
    logging.basicConfig(level=logging.INFO, format="[%(asctime)s][%(name)s][%(levelname)s] - %(message)s")
    import signal

    from aamsim.stop_signals import StopSignals
    from rlbridge.experiment.train import TrainingStopped

    try:
        # Both stop signals interrupt, also in a background job (started with SIGINT ignored); a training
        # run installs its own handler (stop at an iteration boundary) for its length.
        with StopSignals(signal.default_int_handler):
            run_study(plan, args.work, out, tuple(args.stages))
    except TrainingStopped as stopped:
        run = stopped.run_dir.relative_to(args.work) if stopped.run_dir.is_relative_to(args.work) else stopped.run_dir
        print(f"study stopped by {stopped.signal_name} after iteration {stopped.iteration} of {run}: the same "
              "command continues it from there (--park first to commit it)", file=sys.stderr)
        raise SystemExit(130) from None
    except KeyboardInterrupt:
        print("study interrupted: the same command continues it (an evaluation keeps the episodes it finished, "
              "a training run continues from its last checkpoint)", file=sys.stderr)
        raise SystemExit(130) from None
    print(out)
