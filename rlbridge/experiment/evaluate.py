"""``aamgym evaluate``: frozen weights against the baselines on the same seeds (Hydra app).

Runs ``episodes`` episodes (seeds ``seed .. seed + episodes - 1``; each seed draws its own
altitude noise, ``alt_noise_ft``) of the trained policy loaded from the run's
``checkpoints/best.pt``, and of each baseline on the same seeds. Writes:

* ``episodes/<policy>/seed-NNNN/summary.json`` — the ``aamsim run`` schema, so that
  ``aamsim compare <eval>/episodes/<policy> <eval>/episodes/unequipped`` works too;
* ``episodes.csv`` — one row per (policy, seed) with the main metrics;
* ``episode_metrics.csv`` — one row per (policy, seed) with every metric of its ``summary.json``, flat
  (what ``aamgym report`` reads when the per-episode folders are not there: a committed evaluation);
* ``evaluation.json`` — risk ratio and LoWC ratio (mean, std and pooled over seed pairs,
  :mod:`aamsim.metrics.compare`) and mean safety/operational metrics per policy.

The frozen policy acts greedily by default (D2MAV-A: its most likely action, DDQN: argmax Q);
``greedy=false`` samples D2MAV-A's stochastic policy instead, and makes DDQN epsilon-greedy with
``sampled_epsilon`` (0.05, Mnih et al.'s evaluation protocol; :data:`SAMPLED_EPSILON`).

An episode is decided by its seed, the environment and what acts in it (each episode draws its actions
from a generator seeded by its seed), so with an ``episode_cache`` directory each one is played once and
reused: a baseline's (the unequipped aircraft, MVP, DAA, ...) by every evaluation on the same scenario,
use-case parameters and code, the policy's by a rerun with the same weights and the same way of acting,
so an evaluation that was interrupted resumes with the episodes it had finished (``aamgym study`` and
``aamgym scores`` pass one). Nothing is cached while the package's sources differ from their commit.

``baseline=<name>`` instead of ``run=`` evaluates a baseline (``unequipped``, ``mvp_speed``,
``daa``) against the others with no training run: on ``scenario=`` with the use case of
the ``usecase`` config group (``usecase.params.*`` overrides). An unknown baseline name is
an error listing the known ones.
"""

from __future__ import annotations

import csv
import json
import logging
from dataclasses import fields as dataclass_fields
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import DictConfig, OmegaConf

from aamsim.metrics.compare import compare_runs, expand_runs
from rlbridge.agents import BASELINE_KINDS
from rlbridge.agents.rollout import EnvSpec, EpisodeStats
from rlbridge.experiment.report import write_episode_metrics
from rlbridge.experiment.train import find_checkpoint, load_checkpoint, resolve_scenario_path
from rlbridge.experiment.workers import make_pool
from rlbridge.policies import make_usecase_with_policies
from rlbridge.usecases.registry import usecase_spec

log = logging.getLogger("aamgym.evaluate")

BASELINE_LABELS = {"unequipped": "Unequipped", "mvp_speed": "MVP speed-only (rule-based)",
                   "daa": "DAA speed-only (DO-365/DAIDALUS)", "mvp": "MVP heading/altitude (rule-based)",
                   "no_planning": "No planning (depart on schedule)", "fcfs": "FCFS strategic deconfliction"}
CSV_COLUMNS = ("policy", "seed", "nmac_events", "lowc_events", "reward_per_aircraft", "aircraft", "aircraft_states",
               "sim_s", "wall_s", "flights_completed", "alert_rate_per_flight_hour", "airborne_holding_s",
               "mean_flight_time_s", "mean_delay_s", "min_separation_m")


def baseline_label(name: str, env: EnvSpec) -> str:
    """A baseline's label in reports; ``daa`` says which advisories it gives on the use case."""
    if name == "daa":
        # The instance's spec: the hierarchical use case's aircraft actions depend on its ``train``.
        kinds = make_usecase_with_policies(env.usecase, **env.params).spec.action_kinds
        if "speed" not in kinds:
            return f"DAA {'/'.join(kinds)} (DO-365/DAIDALUS)"
    return BASELINE_LABELS.get(name, name)


# What "sampled actions" means for a value-based policy (DDQN has no action distribution): epsilon-greedy
# with epsilon = 0.05, the evaluation protocol of Mnih et al. (2015, Nature, "Methods: evaluation
# procedure"). Its training schedule ends at 1e-4, which would be greedy in all but name.
SAMPLED_EPSILON = 0.05


def numpy_weights(state: dict[str, Any]) -> dict[str, np.ndarray]:
    return {k: v.detach().cpu().numpy() for k, v in state.items()}


def _mean_std(values: list[Any]) -> dict[str, float | None]:
    xs = [float(v) for v in values if v is not None]
    if not xs:
        return {"mean": None, "std": None}
    return {"mean": float(np.mean(xs)), "std": float(np.std(xs))}


def group_means(stats: list[EpisodeStats], group: str) -> dict[str, dict[str, float | None]]:
    keys = sorted({k for s in stats for k in s.metrics.get(group, {})})
    return {k: _mean_std([s.metrics.get(group, {}).get(k) for s in stats]) for k in keys}


def evaluation_env(cfg: DictConfig, trained_env: EnvSpec) -> EnvSpec:
    """The episode settings of an evaluation: the training run's, overridden by ``cfg``.

    ``backend`` chooses where the episodes run (``bluesky``: BlueSky flies the aircraft, so a
    policy trained on aamsim is checked on BlueSky itself). ``scenario``, ``env.time_limit_s``
    and ``env.dt`` left null keep the training run's values (a training run's own null time limit stays null: the engine's default, last
    command of the evaluated scenario + 2 h); the altitude noise and metrics are the
    evaluation's.
    """
    scenario = resolve_scenario_path(str(cfg.scenario)) if cfg.scenario else trained_env.scenario
    params = with_altitude_noise(trained_env.usecase, dict(trained_env.params), float(cfg.alt_noise_ft),
                                 [float(x) for x in cfg.alt_noise_lanes_ft])
    backend = str(cfg.get("backend") or "local")
    return replace(trained_env, scenario=scenario, params=params, metrics=tuple(cfg.metrics), backend=backend,
                   time_limit_s=trained_env.time_limit_s if cfg.env.time_limit_s is None
                   else float(cfg.env.time_limit_s),
                   dt=trained_env.dt if cfg.env.dt is None else float(cfg.env.dt))


def check_baselines(names: list[str]) -> None:
    """Unknown baseline names are an error listing the known ones."""
    unknown = [n for n in names if n not in BASELINE_KINDS]
    if unknown:
        raise ValueError(f"unknown baseline(s) {', '.join(unknown)}; known: {', '.join(BASELINE_KINDS)}")


def baseline_env(cfg: DictConfig) -> EnvSpec:
    """The episode settings of a baseline evaluation (no training run): the scenario and use case of ``cfg``."""
    if not cfg.scenario:
        raise ValueError("baseline=... evaluates on scenario=...: give a scenario (e.g. scenario=nyc_train_100)")
    params = dict(OmegaConf.to_container(cfg.usecase.params, resolve=True))  # type: ignore[arg-type]
    return EnvSpec(resolve_scenario_path(str(cfg.scenario)), str(cfg.usecase.name), params,
                   None if cfg.env.time_limit_s is None else float(cfg.env.time_limit_s),
                   0.05 if cfg.env.dt is None else float(cfg.env.dt), tuple(cfg.metrics))


def with_altitude_noise(usecase: str, params: dict[str, Any], noise_ft: float, lanes_ft: list[float]) -> dict[str, Any]:
    """The evaluation's altitude noise given to the use case that flies aircraft as agents (corridor_sa, and
    the hierarchical use case's corridor level); a planner's flights keep their scenario's noise."""
    noise = {"alt_noise_ft": noise_ft, "alt_noise_lanes_ft": lanes_ft}
    fields = {f.name for f in dataclass_fields(usecase_spec(usecase).params_class)}
    if "alt_noise_ft" in fields:
        # A planner's params may take the noise's size but fly their own layers (no lanes to give).
        return {**params, **{k: v for k, v in noise.items() if k in fields}}
    if "corridor" in fields and params.get("train") == "tactical":
        return {**params, "corridor": {**params.get("corridor", {}), **noise}}
    return params


def evaluation_baselines(cfg: DictConfig, env: EnvSpec) -> list[str]:
    """The baselines to evaluate: ``cfg.baselines``, or (null) the use case's own (its spec's ``baselines``);
    each must be one its spec lists and must fit it (rlbridge.agents.check_baseline_fits)."""
    from rlbridge.agents import BASELINE_KINDS, check_baseline_fits

    usecase = make_usecase_with_policies(env.usecase, **env.params)
    applies = usecase.spec.baselines
    names = [str(b) for b in cfg.baselines] if cfg.baselines is not None else list(applies)
    for b in names:
        if b not in BASELINE_KINDS:
            raise ValueError(f"unknown baseline {b!r}; known: {', '.join(BASELINE_KINDS)}")
        if b != "unequipped" and b not in applies:
            raise ValueError(f"baseline {b!r} does not apply to use case {env.usecase}; its baselines: unequipped, "
                             f"{', '.join(b for b in BASELINE_KINDS if b in applies and b != 'unequipped')}")
        check_baseline_fits(b, usecase)
    return names


def weights_digest(weights: dict[str, np.ndarray]) -> str:
    """SHA-256 of a policy's weights (names, dtypes, shapes and values): the same digest for the same bits."""
    import hashlib

    h = hashlib.sha256()
    for name in sorted(weights):
        a = np.ascontiguousarray(weights[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def episode_cache_spec(spec: dict[str, Any], weights: dict[str, np.ndarray] | None,
                       explore: dict[str, Any]) -> dict[str, Any]:
    """What decides an actor's episodes beside the environment and the seed: a baseline's spec; a learned
    policy's spec, weights and way of acting (greedy, sampled, epsilon)."""
    if weights is None:
        return spec  # a baseline: the key it always had (its cached episodes stay valid)
    return {**spec, "weights_sha256": weights_digest(weights), "explore": explore}


def episode_cache_dir(root: Path, env: EnvSpec, spec: dict[str, Any]) -> Path | None:
    """Where an actor's episodes on ``env`` are kept: a digest of everything that decides them (the
    scenario's text, the use case and its parameters, step, time limit, metrics, backend, the actor's
    spec from :func:`episode_cache_spec` and the code's commit). None when the code has uncommitted changes:
    nothing is cached then."""
    import hashlib

    from rlbridge.experiment.train import code_version

    commit = code_version().get("commit", "")
    if not commit or commit.endswith("+dirty"):
        return None
    text = Path(env.scenario).read_bytes() if Path(env.scenario).is_file() else env.scenario.encode()
    key = {"scenario_sha256": hashlib.sha256(text).hexdigest(), "usecase": env.usecase, "params": env.params,
           "time_limit_s": env.time_limit_s, "dt": env.dt, "metrics": list(env.metrics), "backend": env.backend,
           "policy": spec, "commit": commit}
    digest = hashlib.sha256(json.dumps(key, sort_keys=True, default=str).encode()).hexdigest()[:24]
    return root / f"{spec['kind']}-{digest}"


def write_episode_summary(out: Path, policy: str, stats: EpisodeStats) -> None:
    """``episodes/<policy>/seed-NNNN/summary.json``: the ``aamsim run`` schema (``aamsim compare`` reads it)."""
    d = out / "episodes" / policy / f"seed-{stats.seed:04d}"
    d.mkdir(parents=True, exist_ok=True)
    (d / "summary.json").write_text(json.dumps({**stats.summary(), "policy": policy}, indent=2) + "\n")


def load_cached_episode(cache: Path, seed: int) -> EpisodeStats | None:
    path = cache / f"seed-{seed:04d}.json"
    if not path.is_file():
        return None
    return EpisodeStats(**json.loads(path.read_text()))


def store_cached_episode(cache: Path, stats: EpisodeStats) -> None:
    cache.mkdir(parents=True, exist_ok=True)
    tmp = cache / f".seed-{stats.seed:04d}.tmp"
    tmp.write_text(json.dumps(stats.to_dict()) + "\n")
    tmp.replace(cache / f"seed-{stats.seed:04d}.json")


def run_evaluation(cfg: DictConfig, out_dir: str | Path, episode_cache: str | Path | None = None) -> dict[str, Any]:
    out = Path(out_dir)
    has_run = cfg.get("run") not in (None, "")
    subject = cfg.get("baseline")
    pretrained = cfg.get("policy")
    given = [k for k, v in (("run", has_run), ("baseline", subject is not None), ("policy", pretrained)) if v]
    if len(given) != 1:
        raise ValueError("give one of run=<training run> (a trained policy against the baselines), "
                         "policy=pretrained:<name> or policy=<exported policy folder>, or baseline=<name> (a baseline "
                         f"against the others), not {' and '.join(given) if given else 'none'}; "
                         f"baselines: {', '.join(BASELINE_KINDS)}")
    check_baselines(([str(b) for b in cfg.baselines] if cfg.baselines is not None else [])
                    + ([str(subject)] if subject is not None else []))
    out.mkdir(parents=True, exist_ok=True)
    (out / "resolved_config.yaml").write_text(OmegaConf.to_yaml(cfg, resolve=True))
    if pretrained:
        return evaluate_pretrained(cfg, out, str(pretrained), episode_cache)
    weights: dict[str, np.ndarray] | None = None
    ckpt: dict[str, Any] = {"state": {}}
    ckpt_path: Path | None = None
    if has_run:
        which = str(cfg.checkpoint)
        ckpt_path = Path(which) if which not in ("best", "last") else find_checkpoint(str(cfg.run), which)
        ckpt = load_checkpoint(ckpt_path)
        algo = ckpt["algorithm"]
        trained_env = EnvSpec(**{**ckpt["env"], "metrics": tuple(ckpt["env"]["metrics"])})
        env = evaluation_env(cfg, trained_env)
        name = str(algo["name"])
        label = str(cfg.name or algo.get("label", name))
        if algo["kind"] == "d2mava":
            greedy = bool(algo["params"].get("greedy_eval", True)) if cfg.greedy is None else bool(cfg.greedy)
            explore: dict[str, Any] = {"greedy": greedy}
        else:
            greedy = True if cfg.greedy is None else bool(cfg.greedy)
            explore = {"epsilon": 0.0 if greedy else float(cfg.get("sampled_epsilon", SAMPLED_EPSILON))}
        actors: dict[str, dict[str, Any]] = {name: {"kind": algo["kind"], "config": algo["params"],
                                                    "dims": ckpt["dims"]}}
        weights = numpy_weights(ckpt["learner"]["model"])
    else:
        name = str(subject)
        label = str(cfg.name or baseline_label(name, baseline_env(cfg)))
        env = evaluation_env(cfg, baseline_env(cfg))
        greedy, explore = True, {}
        actors = {name: {"kind": name}}
    return play_and_report(cfg, out, env, name, label, actors, weights, explore, greedy, has_run, ckpt, ckpt_path,
                           episode_cache)


def evaluate_pretrained(cfg: DictConfig, out: Path, which: str, episode_cache: str | Path | None) -> dict[str, Any]:
    """``policy=pretrained:<name>`` (or an exported policy folder): the shipped weights against the baselines,
    on ``scenario`` (default: the policy's training scenario), in the use case it was trained for."""
    from rlbridge.experiment.export import policy_env
    from rlbridge.pretrained import load

    policy = load(which)
    exported = policy.exported
    trained_env = policy_env(exported, str(cfg.scenario or exported.provenance["training_scenario"]))
    env = evaluation_env(cfg, trained_env)
    name, kind = exported.name, exported.actor_spec["kind"]
    label = str(cfg.name or exported.label)
    greedy = True if cfg.greedy is None else bool(cfg.greedy)
    if kind == "d2mava":
        explore: dict[str, Any] = {"greedy": greedy}
    else:
        explore = {"epsilon": 0.0 if greedy else float(cfg.get("sampled_epsilon", SAMPLED_EPSILON))}
    actors = {name: dict(exported.actor_spec)}
    prov = exported.provenance
    ckpt = {"state": {"best_iteration": prov.get("best_iteration"), "iteration": prov.get("iterations")},
            "run_dir": f"pretrained:{name}" if which.removeprefix("pretrained:") == name else Path(which).name}
    return play_and_report(cfg, out, env, name, label, actors, exported.weights, explore, greedy, True, ckpt, None,
                           episode_cache)


def play_and_report(cfg: DictConfig, out: Path, env: EnvSpec, name: str, label: str,
                    actors: dict[str, dict[str, Any]], weights: dict[str, np.ndarray] | None,
                    explore: dict[str, Any], greedy: bool, has_run: bool, ckpt: dict[str, Any],
                    ckpt_path: Path | None, episode_cache: str | Path | None) -> dict[str, Any]:
    """Play the policy and the baselines on the same seeds; write the episodes, episodes.csv, evaluation.json."""
    scenario = env.scenario
    actors.setdefault("unequipped", {"kind": "unequipped"})
    for b in evaluation_baselines(cfg, env):
        actors.setdefault(b, {"kind": b})
    labels = {name: label, **{b: baseline_label(b, env) for b in actors if b != name}}
    seeds = list(range(int(cfg.seed), int(cfg.seed) + int(cfg.episodes)))
    # A baseline evaluated as the subject has no checkpoint to name; shipped weights name their policy.
    where = ckpt_path if ckpt_path is not None else ckpt.get("run_dir")
    source = f" ({where}, iteration {ckpt['state'].get('best_iteration')})" if has_run else ""
    log.info("evaluating %s%s on %s (%s backend): %d episodes each for %s", label, source, Path(scenario).name,
             env.backend, len(seeds), ", ".join(actors))
    from tqdm import tqdm

    results: dict[str, list[EpisodeStats]] = {}
    pool = make_pool(int(cfg.workers), env, actors, cfg.ray)
    try:
        for policy, spec in actors.items():
            w = weights if policy == name else None
            ex = explore if policy == name else {}
            got: list[EpisodeStats] = []
            cache = None if episode_cache is None else \
                episode_cache_dir(Path(episode_cache), env, episode_cache_spec(spec, w, ex))
            cached = [c for c in (load_cached_episode(cache, s) for s in seeds) if c is not None] if cache else []
            todo = [s for s in seeds if s not in {c.seed for c in cached}]
            if cached:
                log.info("%s: %d of %d episodes reused from the episode cache (%s)", policy, len(cached), len(seeds),
                         "played before" if w is None else "the same weights played them before")
            bar = tqdm(total=len(seeds), desc=policy, unit="ep", leave=False, disable=None, mininterval=2.0,
                       initial=len(cached))
            for stats in cached:
                write_episode_summary(out, policy, stats)
                got.append(stats)
            for stats in pool.map_episodes(todo, policy, w, ex, record=False) if todo else ():
                write_episode_summary(out, policy, stats)
                if cache is not None:
                    store_cached_episode(cache, stats)
                got.append(stats)
                bar.update(1)
            bar.close()
            got.sort(key=lambda s: s.seed)
            results[policy] = got
            log.info("%s: NMAC %.2f +- %.2f, LoWC %.2f per episode, reward/aircraft %.4f", policy,
                     np.mean([s.nmac_events for s in got]), np.std([s.nmac_events for s in got]),
                     np.mean([s.lowc_events for s in got]), np.mean([s.reward_per_aircraft for s in got]))
    finally:
        pool.shutdown()
    if cfg.get("video"):
        record_videos(out, env, actors, name, weights, explore, seeds[0], labels, results, cfg)
    with open(out / "episodes.csv", "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(CSV_COLUMNS)
        for policy, got in results.items():
            for s in got:
                op, sa = s.metrics.get("operational", {}), s.metrics.get("safety", {})
                wr.writerow([policy, s.seed, s.nmac_events, s.lowc_events, f"{s.reward_per_aircraft:.6g}", s.aircraft,
                             s.transitions, s.sim_s, f"{s.wall_s:.3f}", op.get("flights_completed"),
                             op.get("alert_rate_per_flight_hour"), op.get("airborne_holding_s"),
                             op.get("mean_flight_time_s"), op.get("mean_delay_s"), sa.get("min_separation_m")])
    write_episode_metrics(out / "episode_metrics.csv",
                          {policy: [s.summary() for s in got] for policy, got in results.items()})
    base_runs = expand_runs([out / "episodes" / "unequipped"])
    policies: dict[str, Any] = {}
    for policy, got in results.items():
        comp = compare_runs(expand_runs([out / "episodes" / policy]), base_runs)
        policies[policy] = {
            "label": labels[policy], "learned": has_run and policy == name,
            "risk_ratio": comp.to_dict()["risk_ratio"], "lowc_ratio": comp.to_dict()["lowc_ratio"],
            "per_seed": comp.per_seed,
            "nmac_events": _mean_std([s.nmac_events for s in got]),
            "lowc_events": _mean_std([s.lowc_events for s in got]),
            "reward_per_aircraft": _mean_std([s.reward_per_aircraft for s in got]),
            "aircraft_states": int(sum(s.transitions for s in got)), "wall_s": float(sum(s.wall_s for s in got)),
            "safety": group_means(got, "safety"), "operational": group_means(got, "operational")}
    first = next(iter(results.values()))[0]
    evaluation = {"scenario": first.scenario, "scenario_sha256": first.scenario_sha256, "backend": env.backend,
                  "usecase": {"name": env.usecase, "variant": str(env.params.get("variant", "paper"))},
                  "episodes": len(seeds),
                  "seeds": seeds, "alt_noise_ft": float(cfg.alt_noise_ft),
                  "alt_noise_lanes_ft": [float(x) for x in cfg.alt_noise_lanes_ft], "greedy": greedy,
                  "explore": explore,
                  "checkpoint": None if ckpt_path is None else str(ckpt_path), "train_run": ckpt.get("run_dir"),
                  "algorithm": name,
                  "best_iteration": ckpt["state"].get("best_iteration"),
                  "trained_iterations": ckpt["state"].get("iteration"),
                  "policies": policies}
    (out / "evaluation.json").write_text(json.dumps(evaluation, indent=2) + "\n")
    rr = policies[name]["risk_ratio"]
    log.info("%s on %s: risk ratio %s, LoWC ratio %s (evaluation.json in %s)", label, first.scenario,
             _ratio_text(rr), _ratio_text(policies[name]["lowc_ratio"]), out)
    return evaluation


def record_videos(out: Path, env: EnvSpec, actors: dict[str, dict[str, Any]], name: str, weights: Any,
                  explore: dict[str, Any], seed: int, labels: dict[str, str], results: dict[str, list[Any]],
                  cfg: DictConfig) -> None:
    """``video=true``: the first seed's episode of each policy beside the unequipped one (episode_video)."""
    from rlbridge.experiment.episode_video import record_episode, write_comparison_video

    dirs: dict[str, Path] = {}
    for policy, spec in actors.items():
        d = out / "episodes" / policy / f"seed-{seed:04d}"
        stats = record_episode(env, policy, spec, weights if policy == name else None,
                               explore if policy == name else {}, seed, d)
        scored = next(s for s in results[policy] if s.seed == seed)
        if (stats.nmac_events, stats.lowc_events) != (scored.nmac_events, scored.lowc_events):
            raise RuntimeError(f"{policy}, seed {seed}: the recorded episode ({stats.nmac_events} NMAC, "
                               f"{stats.lowc_events} LoWC) is not the one evaluated ({scored.nmac_events} NMAC, "
                               f"{scored.lowc_events} LoWC)")
        dirs[policy] = d
    videos = out / "videos"
    videos.mkdir(exist_ok=True)
    for policy, d in dirs.items():
        if policy == "unequipped":
            continue
        path = videos / f"{policy}_vs_unequipped_seed-{seed:04d}.mp4"
        n = write_comparison_video(d, labels[policy], dirs["unequipped"], path, float(cfg.video_speed),
                                   float(cfg.video_fps))
        log.info("video: %s (%d frames)", path, n)


def _ratio_text(r: dict[str, Any]) -> str:
    if r.get("mean") is None:
        return "undefined (no baseline events)"
    return f"{r['mean']:.4f} +- {r['std']:.4f} (pooled {r['pooled']:.4f})"


def hydra_entry() -> None:
    """The Hydra app (``aamgym evaluate ...``)."""
    import hydra
    from hydra.core.hydra_config import HydraConfig

    from rlbridge.experiment.configstore import register_configs

    register_configs()

    @hydra.main(config_path="../conf", config_name="evaluate", version_base="1.3")
    def _main(cfg: DictConfig) -> None:
        run_evaluation(cfg, HydraConfig.get().runtime.output_dir)

    _main()
