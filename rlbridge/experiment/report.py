"""``aamgym report``: the paper's tables and figures from evaluation and training runs.

    aamgym report EVAL_DIR [EVAL_DIR ...] [--train TRAIN_DIR ...] [-o OUT] [--smooth N]

Tables (CSV and Markdown; rows: algorithms, columns: scenarios; cells ``mean ± std`` over
seed-paired episodes, as in the paper's tables, then the 95 % interval (Student's t) over the
training runs, or over the episodes for a baseline):

* ``risk_ratio.csv/.md`` — NMAC events / unequipped NMAC events on the same seed;
* ``lowc_ratio.csv/.md`` — the same with LoWC events;

  beside each ratio, what it cost, per episode (:data:`COST_COLUMNS`): flights completed,
  airborne holding (seconds, share of flights), aircraft parked (hovering) at the time limit,
  mean delay, advisories per flight hour; a policy that leaves aircraft hovering at the time
  limit has "PARKS AIRCRAFT" in its row's name;
* ``operational.csv/.md`` — safety counts and operational metrics per algorithm and scenario;
* ``planning.csv/.md`` — for planner runs (``strategic_planning``, ``hierarchical``): throughput,
  mean and 95th-percentile departure delay, flights planned, unplaced requests, safety;
* ``nmac_encounters.csv/.md`` — NMAC events per episode by their geometry at the closest
  point (same-direction, head-on, crossing, vertical, hover: docs/metrics.md), which tells
  what a speed-only resolution could have avoided.

Figures (PNG, from the training runs' ``learning_curve.csv``):

* ``reward_curve.png`` (``reward_curve_<variant>.png`` for another use-case variant: rewards of two
  variants are never drawn on one axis) — mean reward per aircraft per iteration with a 95 % confidence band
  (Student's t over the training runs of the same algorithm, on the iterations all of them
  reached; for a single run, over the iteration's episodes), zoomed view on top and full view
  below, the unequipped baseline dashed;
* ``nmac_curve.png`` — NMAC events per aircraft per iteration, 95 % band;
* ``states_per_hour.png`` — aircraft-states generated per wall-clock hour (and cumulative).

``report.md`` gathers everything. Evaluations of different use-case configurations (the
paper's reward, variant ``v1``, ...) get separate tables (``risk_ratio.md``,
``risk_ratio_v1.md``, ...): their rows are never mixed; where two use cases would get the same
name (two use cases' own configurations in one report) the use case's name goes before the variant
(``risk_ratio_corridor_sa.md``, ``risk_ratio_strategic_planning.md``). Several evaluation runs of the same algorithm and
scenario (e.g. training seeds) are pooled; baselines evaluated twice on a seed count once.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from collections import Counter, defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from aamsim.metrics.stats import mean_interval

BACKEND_LABELS = {"bluesky": "on BlueSky"}
OPERATIONAL_COLUMNS = (
    ("nmac_events", "NMAC / episode"), ("lowc_events", "LoWC / episode"),
    ("safety.nmac_per_flight", "NMAC / flight"), ("operational.flights_completed", "flights completed"),
    ("operational.alert_rate_per_flight_hour", "alerts / flight hour"),
    ("operational.airborne_holding_s", "airborne holding [s]"),
    ("operational.holding_flight_share", "holding flight share"),
    ("operational.parked_at_time_limit", "parked at time limit"),
    ("operational.mean_flight_time_s", "mean flight time [s]"), ("operational.mean_delay_s", "mean delay [s]"),
    ("reward_per_aircraft", "reward / aircraft"))
# The planner's metrics (strategic_planning, hierarchical): both levels of a hierarchical run in one table.
PLANNING_GROUPS = ("strategic_planning", "hierarchical")
PLANNING_COLUMNS = (
    ("planning.throughput_per_hour", "throughput [flights/h]", 1), ("planning.mean_delay_s", "mean delay [s]", 1),
    ("planning.p95_delay_s", "p95 delay [s]", 1), ("planning.flights_planned", "flights planned", 1),
    ("planning.unplaced", "unplaced", 2), ("planning.layer_changes", "layer changes", 1),
    ("planning.intent_conflicts", "intent conflicts", 1), ("nmac_events", "NMAC / episode", 2),
    ("lowc_events", "LoWC / episode", 2), ("operational.advisories", "tactical advisories", 1))


# ------------------------------------------------------------------------------- tables
@dataclass
class Cell:
    """Seed-paired ratios and per-episode values of one (algorithm, scenario)."""

    risk: dict[tuple[str, Any], float | None] = field(default_factory=dict)  # (eval dir or "", seed) -> ratio
    lowc: dict[tuple[str, Any], float | None] = field(default_factory=dict)
    values: dict[str, list[float]] = field(default_factory=lambda: defaultdict(list))
    seen: set[str] = field(default_factory=set)  # episodes already counted (owner|seed)


def mean_std(xs: list[float]) -> tuple[float, float] | None:
    xs = [x for x in xs if x is not None and not (isinstance(x, float) and math.isnan(x))]
    if not xs:
        return None
    return float(np.mean(xs)), float(np.std(xs))


def fmt_pm(ms: tuple[float, float] | None, digits: int = 4) -> str:
    return "n/a" if ms is None else f"{ms[0]:.{digits}f} ± {ms[1]:.{digits}f}"


def load_evaluations(dirs: list[Path]) -> tuple[dict[str, dict[str, Cell]], list[str], list[str]]:
    """label -> scenario -> Cell; plus the label and scenario orders."""
    cells: dict[str, dict[str, Cell]] = defaultdict(lambda: defaultdict(Cell))
    labels: list[str] = []
    scenarios: list[str] = []
    learned: list[str] = []
    for d in dirs:
        ev = json.loads((d / "evaluation.json").read_text())
        # Evaluations on BlueSky (`aamgym evaluate backend=bluesky`) get their own columns, beside aamsim's.
        scen = ev["scenario"] + (f" ({BACKEND_LABELS.get(ev['backend'], ev['backend'])})"
                                 if ev.get("backend", "local") != "local" else "")
        if scen not in scenarios:
            scenarios.append(scen)
        episodes = _episode_rows(d)
        for policy, p in ev["policies"].items():
            label = p["label"]
            if label not in labels:
                labels.append(label)
                if p.get("learned"):
                    learned.append(label)
            cell = cells[label][scen]
            owner = str(d) if p.get("learned") else ""  # baselines: the same seed counts once
            for row in p["per_seed"]:
                cell.risk[(owner, row["seed"])] = row["risk_ratio"]
                cell.lowc[(owner, row["seed"])] = row["lowc_ratio"]
            for seed, values in episodes.get(policy, {}).items():
                key = f"{owner}|{seed}"
                if key in cell.seen:
                    continue
                cell.seen.add(key)
                for k, v in values.items():
                    cell.values[k].append(v)
    order = learned + [lb for lb in labels if lb not in learned]
    return cells, order, scenarios


def flat_episode_metrics(summary: dict[str, Any]) -> dict[str, float]:
    """One episode's ``summary.json`` (the ``aamsim run`` schema) as the flat numbers the tables read:
    ``reward_per_aircraft``, ``nmac_events``, ``lowc_events`` and ``<group>.<metric>``."""
    flights = max(summary.get("flights_created", 1), 1)
    flat: dict[str, float] = {"reward_per_aircraft": summary.get("reward_total", 0.0) / flights}
    for group in ("safety", "operational") + PLANNING_GROUPS:
        for k, v in (summary.get(group) or {}).items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                flat[f"{'planning' if group in PLANNING_GROUPS else group}.{k}"] = float(v)
    flat["nmac_events"] = flat.get("safety.nmac_events", float("nan"))
    flat["lowc_events"] = flat.get("safety.lowc_events", float("nan"))
    return flat


# The columns of an evaluation's episodes.csv, under the names of flat_episode_metrics (evaluations
# exported before episode_metrics.csv existed carry only these).
_EPISODES_CSV_KEYS = {"nmac_events": "nmac_events", "lowc_events": "lowc_events",
                      "reward_per_aircraft": "reward_per_aircraft", "aircraft": "operational.flights",
                      "flights_completed": "operational.flights_completed",
                      "alert_rate_per_flight_hour": "operational.alert_rate_per_flight_hour",
                      "airborne_holding_s": "operational.airborne_holding_s",
                      "mean_flight_time_s": "operational.mean_flight_time_s",
                      "mean_delay_s": "operational.mean_delay_s", "min_separation_m": "safety.min_separation_m"}


def _number(text: str | None) -> float:
    return float(text) if text not in (None, "", "None") else float("nan")


def _episode_rows(d: Path) -> dict[str, dict[int, dict[str, float]]]:
    """policy -> seed -> flat metrics of an evaluation directory.

    From the per-episode ``summary.json`` files where the directory has them (a study's work
    directory); else from ``episode_metrics.csv`` (the same numbers, exported for committing);
    else from ``episodes.csv`` (evaluations exported before that file: its columns only).
    """
    out: dict[str, dict[int, dict[str, float]]] = defaultdict(dict)
    root = d / "episodes"
    if root.is_dir():
        for summary in sorted(root.glob("*/seed-*/summary.json")):
            s = json.loads(summary.read_text())
            out[summary.parent.parent.name][int(s["seed"])] = flat_episode_metrics(s)
        return out
    table, keys = d / "episode_metrics.csv", None
    if not table.is_file():
        table, keys = d / "episodes.csv", _EPISODES_CSV_KEYS
    if not table.is_file():
        return out
    with open(table, newline="") as fh:
        for row in csv.DictReader(fh):
            if keys is None:
                flat = {k: _number(v) for k, v in row.items() if k not in ("policy", "seed")}
            else:
                flat = {name: _number(row.get(col)) for col, name in keys.items() if col in row}
            out[row["policy"]][int(row["seed"])] = flat
    return out


def write_episode_metrics(path: Path, summaries: dict[str, list[dict[str, Any]]]) -> None:
    """``episode_metrics.csv``: one row per (policy, seed), every number of :func:`flat_episode_metrics`
    (what the tables read, so that an exported evaluation needs no per-episode folders)."""
    rows = [(policy, int(s["seed"]), flat_episode_metrics(s)) for policy, got in summaries.items() for s in got]
    columns = sorted({k for _, _, flat in rows for k in flat})
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["policy", "seed", *columns])
        for policy, seed, flat in rows:
            w.writerow([policy, seed, *(repr(flat[k]) if k in flat else "" for k in columns)])


def write_table(path: Path, header: list[str], rows: list[list[str]], title: str) -> None:
    with open(path.with_suffix(".csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    lines = [f"### {title}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    path.with_suffix(".md").write_text("\n".join(lines) + "\n")


# What every ratio is bought with, beside it in the ratio tables (key, title, digits).
COST_COLUMNS = (
    ("operational.flights_completed", "flights completed", 1),
    ("operational.airborne_holding_s", "airborne holding [s]", 0),
    ("operational.holding_flight_share", "flights holding [%]", 1),
    ("operational.parked_at_time_limit", "parked at time limit", 2),
    ("operational.mean_delay_s", "mean delay [s]", 1),
    ("operational.alert_rate_per_flight_hour", "advisories / flight hour", 1),
)


class Parked(NamedTuple):
    """Aircraft left at the time limit per episode (:func:`parked_per_episode`)."""

    per_episode: float
    kind: str  # "parked" (hovering, recorded) or "airborne" (not arrived: episodes before the record existed)
    note: str  # _part's "(k of N episodes)" when only some episodes recorded it, else ""


def parked_per_episode(c: Cell) -> Parked | None:
    """Mean aircraft left hovering at the time limit per episode, what was counted (``parked`` or
    ``airborne``) and :func:`_part`'s note when only some of the cell's episodes recorded it.

    Episodes recorded before ``parked_at_time_limit`` existed count the flights that had not
    arrived when the time limit cut them (``flights - flights_completed``: airborne, not
    necessarily hovering).
    """
    parked = [v for v in c.values.get("operational.parked_at_time_limit", []) if not math.isnan(v)]
    if parked:
        return Parked(float(np.mean(parked)), "parked", _part(len(parked), c))
    flights = c.values.get("operational.flights", [])
    done = c.values.get("operational.flights_completed", [])
    if flights and len(flights) == len(done):
        return Parked(float(np.mean([f - d for f, d in zip(flights, done)])), "airborne", "")
    return None


def cost_cells(c: Cell | None) -> list[str]:
    """The cost columns of one (algorithm, scenario) cell, means over its episodes."""
    out = []
    for key, _, digits in COST_COLUMNS:
        if c is None:
            out.append("n/a")
            continue
        if key == "operational.parked_at_time_limit":
            p = parked_per_episode(c)
            out.append("n/a" if p is None else
                       f"{p.per_episode:.{digits}f}" + (" (airborne)" if p.kind == "airborne" else p.note))
            continue
        ms = mean_std(c.values.get(key, []))
        scale = 100.0 if key.endswith("share") else 1.0
        out.append("n/a" if ms is None else f"{ms[0] * scale:.{digits}f}" + _part(len(c.values.get(key, [])), c))
    return out


def _part(n: int, c: Cell) -> str:
    """' (n of N episodes)' when a figure is a mean over only some of the cell's episodes (evaluations
    recorded before the metric existed lack it), so that it is never read as the whole cell's."""
    return f" ({n} of {len(c.seen)} episodes)" if 0 < n < len(c.seen) else ""


def parking_note(cells: dict[str, Cell], scenarios: list[str]) -> str:
    """' — PARKS AIRCRAFT: ...' when the policy leaves aircraft hovering at the time limit somewhere."""
    notes = []
    for s in scenarios:
        c = cells.get(s)
        p = parked_per_episode(c) if c is not None else None
        if p is not None and p.per_episode > 0:
            what = "hovering" + p.note if p.kind == "parked" else "not arrived"
            notes.append(f"{p.per_episode:.2f} per episode {what} at the time limit on {s}")
    return " — PARKS AIRCRAFT: " + "; ".join(notes) if notes else ""


def ratio_interval(ratios: dict[tuple[str, Any], float | None]) -> str:
    """The 95 % interval of a ratio, Student's t over the sample that varies what was learned.

    A learned policy's episodes come from its training runs (one evaluation directory each): the
    interval is over the training runs' mean ratios, so two training seeds give 1 degree of freedom
    (t = 12.71), however many episodes each ran. A baseline has no training seed: its interval is
    over the episodes.
    """
    owners: dict[str, list[float]] = defaultdict(list)
    for (owner, _), v in ratios.items():
        if v is not None:
            owners[owner].append(v)
    if not owners:
        return ""
    learned = any(owners)
    sample = [float(np.mean(v)) for v in owners.values()] if learned else owners[""]
    mi = mean_interval(sample)
    what = f"{len(sample)} training run{'s' * (len(sample) != 1)}" if learned else f"{len(sample)} episodes"
    if mi is None or mi.half_width is None:
        return f"; 95 % CI: n/a (1 {'training run' if learned else 'episode'})"
    return f"; 95 % CI over {what}: {mi.mean - mi.half_width:.4f} .. {mi.mean + mi.half_width:.4f}"


def ratio_tables(cells: dict[str, dict[str, Cell]], labels: list[str], scenarios: list[str], out: Path,
                 suffix: str = "", config: str = "") -> list[Path]:
    """Risk and LoWC ratio tables; each scenario's ratio sits beside what it cost (:data:`COST_COLUMNS`)."""
    written = []
    spread = ", mean ± std over seed-paired episodes, and the 95 % interval (Student's t) over training runs"
    for name, attr, title in (("risk_ratio", "risk", "Risk ratio (NMAC / unequipped NMAC)" + spread),
                              ("lowc_ratio", "lowc", "LoWC ratio (LoWC / unequipped LoWC)" + spread)):
        ratio_title = name.replace("_", " ").title().replace("Lowc", "LoWC")
        header = ["Algorithm"]
        for s in scenarios:
            header += [f"{ratio_title} - {s}"] + [f"{t} - {s}" for _, t, _ in COST_COLUMNS]
        rows = []
        for label in labels:
            if label == "Unequipped":
                continue
            row = [label + parking_note(cells[label], scenarios)]
            for s in scenarios:
                c = cells[label].get(s)
                ratios = getattr(c, attr) if c else {}
                vals = list(ratios.values())
                n_undef = sum(v is None for v in vals)
                txt = fmt_pm(mean_std([v for v in vals if v is not None]))
                if c and vals:
                    txt += f" (n={len(vals) - n_undef}" + (f", {n_undef} undefined)" if n_undef else ")")
                    txt += ratio_interval(ratios)
                row += [txt] + cost_cells(c)
            rows.append(row)
        full_title = title + (f" — use case {config}" if config else "") + \
            "; beside each ratio, per episode: what it cost"
        write_table(out / f"{name}{suffix}", header, rows, full_title)
        written += [out / f"{name}{suffix}.csv", out / f"{name}{suffix}.md"]
    return written


def _per_episode_rows(cells: dict[str, dict[str, Cell]], labels: list[str], scenarios: list[str],
                      columns: list[tuple[str, int]]) -> list[list[str]]:
    """One row per (scenario, algorithm): label, scenario, episodes, then ``mean ± std`` of each (key, digits)."""
    rows = []
    for s in scenarios:
        for label in labels:
            c = cells[label].get(s)
            if c is None:
                continue
            row = [label, s, str(len(c.values.get("nmac_events", [])))]
            row += [fmt_pm(mean_std(c.values.get(key, [])), digits) for key, digits in columns]
            rows.append(row)
    return rows


def operational_table(cells: dict[str, dict[str, Cell]], labels: list[str], scenarios: list[str], out: Path,
                      suffix: str = "") -> None:
    header = ["Algorithm", "Scenario", "episodes"] + [title for _, title in OPERATIONAL_COLUMNS]
    columns = [(key, 4 if ("per_flight" in key or "share" in key or "reward" in key) else 2)
               for key, _ in OPERATIONAL_COLUMNS]
    write_table(out / f"operational{suffix}", header, _per_episode_rows(cells, labels, scenarios, columns),
                "Safety and operational metrics, mean ± std over episodes")


def planning_table(cells: dict[str, dict[str, Cell]], labels: list[str], scenarios: list[str], out: Path,
                   suffix: str = "") -> bool:
    """Planner and safety metrics per algorithm and scenario; False (nothing written) without planner runs."""
    if not any(k.startswith("planning.") for row in cells.values() for c in row.values() for k in c.values):
        return False
    header = ["Algorithm", "Scenario", "episodes"] + [title for _, title, _ in PLANNING_COLUMNS]
    rows = _per_episode_rows(cells, labels, scenarios, [(key, digits) for key, _, digits in PLANNING_COLUMNS])
    write_table(out / f"planning{suffix}", header, rows, "Strategic planning: throughput, delay, unplaced requests and "
                "safety, mean ± std over episodes")
    return True


def encounter_table(cells: dict[str, dict[str, Cell]], labels: list[str], scenarios: list[str], out: Path,
                    suffix: str = "") -> None:
    from aamsim.metrics.standard import ENCOUNTERS

    header = ["Algorithm", "Scenario", "episodes", "NMAC / episode"] + list(ENCOUNTERS)
    columns = [("nmac_events", 2)] + [(f"safety.nmac_{kind.replace('-', '_')}", 2) for kind in ENCOUNTERS]
    write_table(out / f"nmac_encounters{suffix}", header, _per_episode_rows(cells, labels, scenarios, columns),
                "NMAC events per episode by encounter geometry at the closest point, mean ± std over episodes")


# ------------------------------------------------------------------------------ figures
@dataclass
class TrainRun:
    path: Path
    label: str
    curve: dict[str, np.ndarray]
    episode_rewards: list[list[float]]
    episode_nmac: list[list[float]]
    baseline: dict[str, Any] | None
    summary: dict[str, Any] | None
    workers: int  # rollout workers (0: in-process)
    config: tuple[str, str] = ("corridor_sa", "paper")  # (use case, variant): rewards of two never share axes


def load_train_run(d: Path) -> TrainRun:
    with open(d / "learning_curve.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    numeric = ("iteration", "wall_s", "reward_mean", "nmac_per_aircraft", "lowc_per_aircraft", "aircraft_states",
               "aircraft_states_total", "states_per_s")
    curve = {k: np.array([float(r[k]) if r.get(k) not in (None, "") else np.nan for r in rows]) for k in numeric}

    def split(col: str) -> list[list[float]]:
        return [[float(x) for x in (r.get(col) or "").split(";") if x] for r in rows]  # a use case's own curve

    summary = json.loads((d / "training_summary.json").read_text()) if (d / "training_summary.json").exists() else None
    baseline = json.loads((d / "baseline.json").read_text()) if (d / "baseline.json").exists() else None
    label, workers, config = _from_config(d)
    # The configuration's label (it names a use-case variant): runs of two rewards are never one curve.
    if not (d / "resolved_config.yaml").exists():
        label = (summary or {}).get("label") or label
    return TrainRun(d, label, curve, split("episode_rewards"),
                    split("episode_nmac_per_aircraft"), baseline, summary, workers, config)


def _from_config(d: Path) -> tuple[str, int, tuple[str, str]]:
    """The algorithm's label, the number of workers and the (use case, variant) of a run (from its
    resolved configuration)."""
    cfg = d / "resolved_config.yaml"
    if cfg.exists():
        from omegaconf import OmegaConf

        c: Any = OmegaConf.load(cfg)
        usecase = c.get("usecase", {})
        variant = str(usecase.get("params", {}).get("variant", "paper"))
        label = str(c.algorithm.get("label", c.algorithm.name)) + ("" if variant == "paper" else f" [{variant}]")
        return label, int(c.get("workers", 1)), (str(usecase.get("name", "corridor_sa")), variant)
    return d.name, 1, ("corridor_sa", "paper")


def smooth(x: np.ndarray, window: int) -> np.ndarray:
    if window <= 1 or len(x) == 0:
        return x
    from rlbridge.agents.core import rolling_mean

    return rolling_mean(x, window)


def band(runs: list[TrainRun], key: str, episodes_attr: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """Iterations, mean, 95 % half-width (Student's t) per iteration, and what the band is over.

    Several runs (training seeds): over the runs, on the iterations every run reached (the curve
    ends where the shortest run ends, so the band never changes meaning along it). One run: over
    that iteration's episodes (its workers); no band with one episode per iteration.
    """
    if len(runs) > 1:
        n_it = min(len(r.curve[key]) for r in runs)
        samples = [[float(r.curve[key][k]) for r in runs] for k in range(n_it)]
        what = f"over {len(runs)} training runs"
    else:
        run = runs[0]
        eps = getattr(run, episodes_attr)
        n_it = len(run.curve[key])
        samples = [eps[k] if k < len(eps) and eps[k] else [float(run.curve[key][k])] for k in range(n_it)]
        what = "over the iteration's episodes of 1 run"
    mean = np.full(n_it, np.nan)
    half = np.zeros(n_it)
    for k, xs in enumerate(samples):
        mi = mean_interval(xs)
        if mi is not None:
            mean[k] = mi.mean
            half[k] = mi.half_width or 0.0
    return np.arange(1, n_it + 1), mean, half, what


def _baseline_value(runs: list[TrainRun], key: str) -> float | None:
    vals = [r.baseline[key] for r in runs if r.baseline and key in r.baseline]
    return float(np.mean(vals)) if vals else None


def reward_figure(plt: Any, groups: dict[str, list[TrainRun]], color_of: dict[str, str], path: Path, window: int,
                  note: str, title: str) -> None:
    """Mean reward per aircraft of each contender of one use-case configuration: zoomed (top) and full
    (bottom) views, 95 % band, the unequipped reference of that configuration's training traffic."""
    fig, (ax_zoom, ax_full) = plt.subplots(2, 1, figsize=(9, 8))
    tails = []
    for label, runs in groups.items():
        it, m, h, what = band(runs, "reward_mean", "episode_rewards")
        m, h = smooth(m, window), smooth(h, window)
        for ax in (ax_zoom, ax_full):
            ax.plot(it, m, color=color_of[label], label=f"{label} (band {what})")
            ax.fill_between(it, m - h, m + h, color=color_of[label], alpha=0.25, linewidth=0)
        # The zoom frames the mean curves after their first fifth (and the unequipped line): with two
        # training runs the Student's t band (t = 12.71) of two runs that disagree spans hundreds of
        # reward units and, framed too, left nothing to see; there it runs off the zoomed view.
        tails.append(m[len(m) // 5:])
    base = [_baseline_value(runs, "reward_mean") for runs in groups.values()]
    base_v = [b for b in base if b is not None]
    for ax in (ax_zoom, ax_full):
        if base_v:
            ax.axhline(float(np.mean(base_v)), color="k", linestyle="--", label="Unequipped")
        ax.set_xlabel("training iteration")
        ax.set_ylabel("mean reward per aircraft")
        ax.grid(alpha=0.3)
    vals = np.concatenate([t[np.isfinite(t)] for t in tails] + [np.array(base_v)]) if tails else np.array(base_v)
    if vals.size:
        lo, hi = float(np.min(vals)), float(np.max(vals))
        pad = 0.15 * (hi - lo or 1.0)
        ax_zoom.set_ylim(lo - pad, hi + pad)
        ax_full.axhspan(lo - pad, hi + pad, color="grey", alpha=0.12, label="zoomed region")
    head = f"{title}: mean reward" if title else "Mean reward"
    ax_zoom.set_title(f"{head} learning curve, 95 % confidence band (Student's t)\n"
                      f"zoomed on the mean curves after their first fifth{note}", fontsize=10)
    ax_full.set_title("Full learning curve")
    ax_full.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def figures(train: list[TrainRun], out: Path, window: int,
            suffixes: dict[tuple[str, str], str] | None = None) -> list[Path]:
    """``reward_curve<sfx>.png`` per use-case configuration (rewards of two configurations measure different
    things, so they never share axes or an unequipped line), ``nmac_curve.png`` (NMAC counts do not depend on
    the reward: every run on one chart) and ``states_per_hour.png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups: dict[str, list[TrainRun]] = defaultdict(list)
    for r in train:
        groups[r.label].append(r)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    color_of = {label: colors[ci % len(colors)] for ci, label in enumerate(groups)}
    written = []
    note = f" (rolling mean over {window} iterations)" if window > 1 else ""

    by_config: dict[tuple[str, str], dict[str, list[TrainRun]]] = defaultdict(dict)
    for label, runs in groups.items():
        by_config[runs[0].config][label] = runs
    configs = sorted(by_config, key=config_order)
    suffixes = suffixes or config_suffixes(configs)
    for config in configs:
        path = out / f"reward_curve{suffixes[config]}.png"
        reward_figure(plt, by_config[config], color_of, path, window, note,
                      config_title(config) if len(configs) > 1 else "")
        written.append(path)

    # Normalised NMAC.
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for label, runs in groups.items():
        it, m, h, what = band(runs, "nmac_per_aircraft", "episode_nmac")
        m, h = smooth(m, window), smooth(h, window)
        ax.plot(it, m, color=color_of[label], label=f"{label} (band {what})")
        ax.fill_between(it, np.maximum(m - h, 0), m + h, color=color_of[label], alpha=0.25, linewidth=0)
    b = [x for x in (_baseline_value(runs, "nmac_per_aircraft") for runs in groups.values()) if x is not None]
    if b:
        ax.axhline(float(np.mean(b)), color="k", linestyle="--", label="Unequipped")
    ax.set_xlabel("training iteration")
    ax.set_ylabel("NMAC events / aircraft")
    ax.set_title("Normalised NMAC learning curve, 95 % confidence band (Student's t)" + note)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "nmac_curve.png", dpi=130)
    plt.close(fig)
    written.append(out / "nmac_curve.png")

    # Aircraft-states per hour.
    fig, (ax_cum, ax_bar) = plt.subplots(1, 2, figsize=(11, 4.5))
    names, rates, per_worker = [], [], []
    for label, runs in groups.items():
        for k, r in enumerate(runs):
            ax_cum.plot(r.curve["wall_s"] / 3600.0, r.curve["aircraft_states_total"] / 1e6,
                        color=color_of[label], label=label if k == 0 else None)
        hourly = [3600.0 * r.curve["aircraft_states_total"][-1] / r.curve["wall_s"][-1] for r in runs
                  if len(r.curve["wall_s"]) and r.curve["wall_s"][-1] > 0]
        workers = [max(r.workers, 1) for r in runs]
        names.append(label)
        rates.append(float(np.mean(hourly)) if hourly else 0.0)
        per_worker.append(float(np.mean([h / w for h, w in zip(hourly, workers)])) if hourly else 0.0)
    ax_cum.set_xlabel("wall-clock time [h]")
    ax_cum.set_ylabel("aircraft-states generated [millions]")
    ax_cum.set_title("Cumulative aircraft-states")
    ax_cum.grid(alpha=0.3)
    ax_cum.legend(fontsize=8)
    x = np.arange(len(names))
    bars = ax_bar.bar(x - 0.2, np.array(rates) / 1e6, 0.4, label="total")
    ax_bar.bar(x + 0.2, np.array(per_worker) / 1e6, 0.4, label="per worker")
    for rect, v in zip(bars, rates):
        ax_bar.annotate(f"{v / 1e6:.2f} M/h", (rect.get_x() + rect.get_width() / 2, rect.get_height()),
                        ha="center", va="bottom", fontsize=8)
    ax_bar.set_xticks(x, names, rotation=15, fontsize=8)
    ax_bar.set_ylabel("aircraft-states per hour [millions]")
    ax_bar.set_title("Aircraft-states generated per hour")
    ax_bar.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "states_per_hour.png", dpi=130)
    plt.close(fig)
    written.append(out / "states_per_hour.png")
    return written


def training_table(train: list[TrainRun], out: Path) -> None:
    header = ["Algorithm", "run", "iterations", "wall-clock [h]", "aircraft-states", "states/s", "states/h",
              "best rolling reward", "best iteration"]
    rows = []
    for r in train:
        s = r.summary or {}
        rows.append([r.label, r.path.name, str(s.get("iterations", len(r.curve["iteration"]))),
                     f"{s.get('wall_s', float('nan')) / 3600.0:.2f}", f"{s.get('aircraft_states', 0):,}",
                     f"{s.get('states_per_s') or 0:.0f}", f"{s.get('states_per_hour') or 0:,.0f}",
                     f"{s.get('best_rolling_reward', float('nan')):.4f}", str(s.get("best_iteration", ""))])
    write_table(out / "training", header, rows, "Training runs and wall-clock metrics")


def usecase_config(ev: dict[str, Any]) -> tuple[str, str]:
    """(use case, variant) of an evaluation; evaluations written before variants existed are the paper's."""
    uc = ev.get("usecase") or {}
    return str(uc.get("name", "corridor_sa")), str(uc.get("variant", "paper"))


def config_order(config: tuple[str, str]) -> tuple[bool, tuple[str, str]]:
    """Sort key of use-case configurations: the paper's first, then by name (tables and figures alike)."""
    return config[1] != "paper", config


def group_by_config(eval_dirs: list[Path]) -> dict[tuple[str, str], list[Path]]:
    """Evaluation directories per use-case configuration, the paper's first: their rows never mix."""
    groups: dict[tuple[str, str], list[Path]] = defaultdict(list)
    for d in eval_dirs:
        groups[usecase_config(json.loads((d / "evaluation.json").read_text()))].append(d)
    return dict(sorted(groups.items(), key=lambda kv: config_order(kv[0])))


def config_suffix(config: tuple[str, str]) -> str:
    """'' for a use case's own configuration, ``_<variant>`` for a variant (file names)."""
    return "" if config[1] == "paper" else f"_{config[1]}"


def config_suffixes(configs: Iterable[tuple[str, str]]) -> dict[tuple[str, str], str]:
    """File-name suffix of each configuration of one report: the variant's (``config_suffix``) where no
    other configuration has it, else the use case's name before it, so two use cases' tables never
    overwrite each other (a planner's report keeps ``planning.csv``; corridor_sa beside
    strategic_planning gives ``risk_ratio_corridor_sa.csv`` and ``risk_ratio_strategic_planning.csv``)."""
    unique = sorted(set(configs), key=config_order)
    short = {c: config_suffix(c) for c in unique}
    taken = Counter(short.values())
    return {c: sfx if taken[sfx] == 1 else f"_{c[0]}{sfx}" for c, sfx in short.items()}


def config_title(config: tuple[str, str]) -> str:
    return f"{config[0]} (the paper's reward)" if config[1] == "paper" else f"{config[0]} variant {config[1]}"


def make_report(eval_dirs: list[Path], train_dirs: list[Path], out: Path, window: int = 1,
                departures: list[str] | None = None) -> list[Path]:
    """Write the tables, figures and ``report.md``; ``departures`` (what differs from the paper's setup)
    is printed under every ratio table, where its results are read."""
    out.mkdir(parents=True, exist_ok=True)
    parts: list[str] = ["# AAM-Gym report", ""]
    departure_text = ["**Departures from the paper in these results:**", ""] + [f"- {d}" for d in departures or []]
    written: list[Path] = []
    groups = group_by_config(eval_dirs)
    runs = [load_train_run(d) for d in train_dirs]
    # One naming for tables and figures alike, over every configuration the report shows.
    suffixes = config_suffixes([*groups, *(r.config for r in runs)])
    for config, dirs in groups.items():
        # One set of tables per use-case configuration: a ratio bought under one reward is not
        # comparable with one bought under another, and a label (an algorithm) appears in both.
        sfx = suffixes[config]
        cells, labels, scenarios = load_evaluations(dirs)
        written += ratio_tables(cells, labels, scenarios, out, sfx, config_title(config))
        operational_table(cells, labels, scenarios, out, sfx)
        encounter_table(cells, labels, scenarios, out, sfx)
        written += [out / f"{n}{sfx}.{e}" for n in ("operational", "nmac_encounters") for e in ("csv", "md")]
        names = ["risk_ratio", "lowc_ratio", "operational", "nmac_encounters"]
        if planning_table(cells, labels, scenarios, out, sfx):
            written += [out / f"planning{sfx}.csv", out / f"planning{sfx}.md"]
            names.insert(0, "planning")
        if len(groups) > 1:
            parts += [f"## Use case {config_title(config)}", ""]
        for name in names:
            parts += [(out / f"{name}{sfx}.md").read_text(), ""]
            if departures and name in ("risk_ratio", "lowc_ratio"):
                parts += [*departure_text, ""]
        # Run names only: a report is meant to be committed, the machine's paths are not.
        parts += ["Evaluation runs: " + ", ".join(d.resolve().name for d in dirs), ""]
    if runs:
        training_table(runs, out)
        written += [out / "training.csv", out / "training.md"]
        drawn = figures(runs, out, window, suffixes)
        written += drawn
        parts += [(out / "training.md").read_text(), ""]
        parts += [f"![{p.stem.replace('_curve', '')}]({p.name})\n" for p in drawn]
    (out / "report.md").write_text("\n".join(parts))
    written.append(out / "report.md")
    return written


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="aamgym report", description=__doc__.split("\n\n")[0])
    ap.add_argument("eval_dirs", nargs="*", type=Path, help="evaluation run directories (with evaluation.json)")
    ap.add_argument("--train", nargs="+", type=Path, default=[], help="training run directories (learning curves)")
    ap.add_argument("-o", "--out", type=Path, default=Path("report"), help="output directory (default: report)")
    ap.add_argument("--smooth", type=int, default=1, help="rolling-mean window of the curves [iterations]")
    args = ap.parse_args(argv)
    if not args.eval_dirs and not args.train:
        ap.error("give evaluation directories and/or --train directories")
    for d in args.eval_dirs:
        if not (d / "evaluation.json").exists():
            ap.error(f"{d}: no evaluation.json (not an 'aamgym evaluate' run)")
    for d in args.train:
        if not (d / "learning_curve.csv").exists():
            ap.error(f"{d}: no learning_curve.csv (not an 'aamgym train' run)")
    for p in make_report(args.eval_dirs, args.train, args.out, args.smooth):
        print(p)
