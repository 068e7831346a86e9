"""Risk ratio and LoWC ratio of runs against their unequipped baseline.

The risk ratio (the paper's definition) is the number of NMAC events of the
equipped run divided by the number in the unequipped baseline on the same
scenario and seed; the LoWC ratio likewise with LoWC events. With several
runs per side they are paired by seed; each pair gives a ratio and the mean
and standard deviation over pairs are reported (as in the paper's tables),
with the pooled ratio (total events / total baseline events) beside them.

A safety ratio alone says nothing of what it cost: beside the ratios, each
side's operational figures (flights completed, unfinished and not departed,
airborne holding, delay, advisories; means over the paired runs) are kept,
and a warning names it when the two sides did not complete the same flights,
where the ratios compare different traffic (an unfinished flight either
stopped counting or flies on and meets others).
"""

from __future__ import annotations

import json
import statistics
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from aamsim.output.summary_file import IncompleteSummary, check_complete


class ComparisonError(ValueError):
    """The runs cannot be compared (different scenarios or seeds, missing metrics)."""


@dataclass(frozen=True)
class RunMetrics:
    path: str
    scenario: str
    scenario_sha256: str
    seed: int | None
    nmac_events: int
    lowc_events: int
    operational: dict[str, Any]


@dataclass(frozen=True)
class RatioStats:
    mean: float | None
    std: float | None
    pooled: float | None
    pairs: int
    undefined_pairs: int  # baseline with zero events: ratio undefined


# The operational figures shown beside the ratios (keys of a summary's "operational"), with their labels.
OPERATIONAL_COLUMNS = (
    ("flights_scheduled", "flights scheduled"),
    ("flights_completed", "flights completed"),
    ("flights_unfinished", "flights unfinished"),
    ("flights_not_departed", "flights not departed"),
    ("airborne_holding_s", "airborne holding [s]"),
    ("mean_delay_s", "mean delay [s]"),
    ("advisories", "advisories"),
)


@dataclass(frozen=True)
class Comparison:
    scenario: str
    runs: int
    risk_ratio: RatioStats
    lowc_ratio: RatioStats
    per_seed: list[dict[str, Any]]
    # {"run": {key: mean over the paired runs or None}, "baseline": {...}} for OPERATIONAL_COLUMNS' keys.
    operational: dict[str, dict[str, float | None]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def load_run(path: str | Path) -> RunMetrics:
    """Read a run directory's (or an episode's) summary.json."""
    p = Path(path)
    summary_path = p / "summary.json" if p.is_dir() else p
    if not summary_path.exists():
        raise ComparisonError(f"{path}: no summary.json (not a run directory)")
    data = json.loads(summary_path.read_text())
    try:
        check_complete(data, str(summary_path))
    except IncompleteSummary as exc:
        raise ComparisonError(str(exc)) from None
    safety = data.get("safety")
    if not safety or "nmac_events" not in safety:
        raise ComparisonError(f"{summary_path}: no safety metrics (run with --metrics safety)")
    return RunMetrics(str(path), data.get("scenario", "?"), data.get("scenario_sha256", ""), data.get("seed"),
                      int(safety["nmac_events"]), int(safety["lowc_events"]), data.get("operational") or {})


def expand_runs(paths: Sequence[str | Path]) -> list[RunMetrics]:
    """Run directories; a directory without summary.json but with run sub-directories counts as many runs."""
    runs: list[RunMetrics] = []
    for path in paths:
        p = Path(path)
        if p.is_dir() and not (p / "summary.json").exists():
            subs = sorted(d for d in p.iterdir() if (d / "summary.json").exists())
            if not subs:
                raise ComparisonError(f"{path}: neither a run directory nor a folder of runs")
            runs.extend(load_run(d) for d in subs)
        else:
            runs.append(load_run(p))
    return runs


def _stats(values: list[tuple[int, int]]) -> RatioStats:
    ratios = [a / b for a, b in values if b > 0]
    undefined = sum(1 for _, b in values if b == 0)
    total_b = sum(b for _, b in values)
    pooled = sum(a for a, _ in values) / total_b if total_b > 0 else None
    mean = statistics.fmean(ratios) if ratios else None
    std = statistics.pstdev(ratios) if len(ratios) > 1 else (0.0 if ratios else None)
    return RatioStats(mean, std, pooled, len(values), undefined)


def compare_runs(runs: list[RunMetrics], baselines: list[RunMetrics]) -> Comparison:
    """Pair runs with baselines by (scenario, seed) and compute the ratios.

    Raises:
        ComparisonError: scenarios or seeds differ, or a run has no partner.
    """
    if not runs or not baselines:
        raise ComparisonError("need at least one run and one baseline")

    def key(r: RunMetrics) -> tuple[str, Any]:
        return (r.scenario_sha256 or r.scenario, r.seed)

    scen = {r.scenario_sha256 or r.scenario for r in runs + baselines}
    if len(scen) > 1:
        names = sorted({f"{r.scenario} ({(r.scenario_sha256 or '?')[:12]})" for r in runs + baselines})
        raise ComparisonError(f"runs of different scenarios cannot be compared: {', '.join(names)}")
    base: dict[tuple[str, Any], RunMetrics] = {}
    for b in baselines:
        if key(b) in base:
            raise ComparisonError(f"two baseline runs with seed {b.seed}: {base[key(b)].path} and {b.path}")
        base[key(b)] = b
    seen = set()
    pairs = []
    for r in runs:
        if key(r) not in base:
            raise ComparisonError(f"run {r.path} (seed {r.seed}) has no baseline with the same seed")
        if key(r) in seen:
            raise ComparisonError(f"two runs with seed {r.seed}")
        seen.add(key(r))
        pairs.append((r, base[key(r)]))
    if len(pairs) != len(base):
        missing = sorted(str(b.seed) for k, b in base.items() if k not in seen)
        raise ComparisonError(f"baseline seeds without a run: {', '.join(missing)}")
    per_seed = [{"seed": r.seed, "nmac": r.nmac_events, "baseline_nmac": b.nmac_events,
                 "risk_ratio": r.nmac_events / b.nmac_events if b.nmac_events else None,
                 "lowc": r.lowc_events, "baseline_lowc": b.lowc_events,
                 "lowc_ratio": r.lowc_events / b.lowc_events if b.lowc_events else None,
                 "flights_completed": r.operational.get("flights_completed"),
                 "baseline_flights_completed": b.operational.get("flights_completed")} for r, b in pairs]
    operational = {"run": _operational_means([r for r, _ in pairs]),
                   "baseline": _operational_means([b for _, b in pairs])}
    return Comparison(
        scenario=runs[0].scenario,
        runs=len(pairs),
        risk_ratio=_stats([(r.nmac_events, b.nmac_events) for r, b in pairs]),
        lowc_ratio=_stats([(r.lowc_events, b.lowc_events) for r, b in pairs]),
        per_seed=per_seed,
        operational=operational,
        warnings=_completion_warnings(pairs),
    )


def _operational_means(runs: list[RunMetrics]) -> dict[str, float | None]:
    """Mean of each operational figure over ``runs``; None where a run lacks it (an older summary)."""
    means: dict[str, float | None] = {}
    for key, _ in OPERATIONAL_COLUMNS:
        values = [float(v) for r in runs if (v := r.operational.get(key)) is not None]
        means[key] = statistics.fmean(values) if values and len(values) == len(runs) else None
    return means


def _completion_warnings(pairs: list[tuple[RunMetrics, RunMetrics]]) -> list[str]:
    """A warning for the seeds where run and baseline completed different numbers of flights."""
    differ = [(r.seed, r.operational.get("flights_completed"), b.operational.get("flights_completed"))
              for r, b in pairs if r.operational.get("flights_completed") != b.operational.get("flights_completed")]
    if not differ:
        return []
    shown = ", ".join(f"seed {seed}: {done} against {base}" for seed, done, base in differ[:5])
    more = f" and {len(differ) - 5} more" if len(differ) > 5 else ""
    return [(f"the run and its baseline completed different numbers of flights ({shown}{more}): the ratios "
             "compare different traffic (an unfinished flight stops counting, or flies on and can meet "
             "others); each side's flights unfinished and not departed are shown beside the ratios")]


def format_operational(comparison: Comparison) -> list[str]:
    """The operational figures of both sides as aligned text lines (a header, then one line per figure)."""
    run, base = comparison.operational.get("run", {}), comparison.operational.get("baseline", {})
    per = "mean per run" if comparison.runs > 1 else "per run"
    lines = [f"{'operational cost (' + per + ')':<34}{'run':>10}{'baseline':>12}"]
    for key, label in OPERATIONAL_COLUMNS:
        a, b = run.get(key), base.get(key)
        if a is None and b is None:
            continue
        lines.append(f"  {label:<32}{_number(a):>10}{_number(b):>12}")
    return lines


def _number(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:,.0f}" if float(value).is_integer() or abs(value) >= 1000 else f"{value:,.1f}"


def format_ratio(stats: RatioStats) -> str:
    if stats.mean is None:
        return "undefined (no baseline events)"
    text = f"{stats.mean:.4f} +- {stats.std:.4f}" if stats.pairs > 1 else f"{stats.mean:.4f}"
    if stats.pairs > 1 and stats.pooled is not None:
        text += f" (pooled {stats.pooled:.4f})"
    if stats.undefined_pairs:
        text += f"; {stats.undefined_pairs} seed(s) without baseline events left out"
    return text
