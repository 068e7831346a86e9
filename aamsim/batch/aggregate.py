"""The batch's tables: one row per run, and mean, std and 95 % confidence interval per scenario and setting.

Every number of a run's ``summary.json`` goes in: the run figures (flights
created and arrived, errors, aircraft-steps...), the ``safety`` group and
the ``operational`` group, so a safety figure is never shown without its
operational cost. A metric that a run leaves empty (``null``: e.g. the mean
delay of a scenario without a schedule) is left out of that metric's
statistics, and ``n`` says how many runs it is taken over. The confidence
interval is Student's t interval of the mean over seeds.
"""

from __future__ import annotations

import csv
import math
import statistics
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aamsim.metrics.stats import t_critical
from aamsim.output.summary_file import check_complete

# Top-level summary fields that are figures of the run (the rest describe it: paths, versions, seeds).
RUN_FIGURES = ("sim_time_s", "wall_time_s", "aircraft_steps", "flights_created", "flights_deleted",
               "flights_arrived", "aircraft_at_end", "errors")
GROUPS = ("safety", "operational")


def flatten_metrics(summary: dict[str, Any]) -> dict[str, float | None]:
    """``summary.json`` -> {metric: value}: run figures, then ``safety.*`` and ``operational.*`` numbers.

    Raises:
        IncompleteSummary: a provisional summary (``"complete": false``): its run was killed, and
            its figures would enter the statistics as if it had finished.
    """
    check_complete(summary, f"summary.json of {summary.get('scenario', '?')} (seed {summary.get('seed')})")
    out: dict[str, float | None] = {}
    for key in RUN_FIGURES:
        if key in summary:
            out[key] = _number(summary[key])
    for group in GROUPS:
        for key, value in (summary.get(group) or {}).items():
            if value is None or isinstance(value, (int, float)) and not isinstance(value, bool):
                out[f"{group}.{key}"] = _number(value)
    return out


def _number(value: Any) -> float | None:
    if value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value)


@dataclass(frozen=True)
class MetricStats:
    """Statistics of one metric over the runs (seeds) of one scenario and setting."""

    n: int
    mean: float | None
    std: float | None  # sample standard deviation (n - 1); None for one run
    ci95_low: float | None
    ci95_high: float | None


def describe(values: Sequence[float]) -> MetricStats:
    """Mean, sample std and Student's t 95 % interval of the mean (no interval below two values)."""
    n = len(values)
    if n == 0:
        return MetricStats(0, None, None, None, None)
    mean = statistics.fmean(values)
    if n == 1:
        return MetricStats(1, mean, None, None, None)
    std = statistics.stdev(values)
    half = t_critical(n - 1) * std / math.sqrt(n)
    return MetricStats(n, mean, std, mean - half, mean + half)


@dataclass(frozen=True)
class RunRow:
    """One run of the batch, as it goes in ``runs.csv``."""

    scenario: str
    setting: str
    seed: int
    node: str
    wall_s: float
    run_dir: str
    error: str | None
    metrics: dict[str, float | None]


def aggregate(rows: Iterable[RunRow]) -> list[tuple[str, str, str, MetricStats]]:
    """(scenario, setting, metric, stats) for every scenario and setting, in first-seen order."""
    groups: dict[tuple[str, str], list[RunRow]] = {}
    for row in rows:
        if row.error is None:
            groups.setdefault((row.scenario, row.setting), []).append(row)
    out = []
    for (scenario, setting), members in groups.items():
        names: dict[str, None] = {}
        for row in members:
            names.update(dict.fromkeys(row.metrics))
        for name in names:
            values = [v for row in members if (v := row.metrics.get(name)) is not None and math.isfinite(v)]
            out.append((scenario, setting, name, describe(values)))
    return out


def _fmt(value: float | None) -> str:
    return "" if value is None else repr(value)


def write_runs_csv(path: Path, rows: Sequence[RunRow]) -> None:
    names: dict[str, None] = {}
    for row in rows:
        names.update(dict.fromkeys(row.metrics))
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["scenario", "setting", "seed", "node", "wall_s", "run_dir", "error", *names])
        for row in rows:
            writer.writerow([row.scenario, row.setting, row.seed, row.node, f"{row.wall_s:.3f}", row.run_dir,
                             row.error or "", *(_fmt(row.metrics.get(n)) for n in names)])


def write_aggregate_csv(path: Path, table: Sequence[tuple[str, str, str, MetricStats]]) -> None:
    """Long form: one line per scenario, setting and metric (what pandas and R like to read)."""
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["scenario", "setting", "metric", "n", "mean", "std", "ci95_low", "ci95_high"])
        for scenario, setting, metric, st in table:
            writer.writerow([scenario, setting, metric, st.n, _fmt(st.mean), _fmt(st.std), _fmt(st.ci95_low),
                             _fmt(st.ci95_high)])


def _cell(st: MetricStats) -> str:
    if st.mean is None:
        return "-"
    text = f"{st.mean:.4g}"
    if st.ci95_low is not None and st.ci95_high is not None:
        text += f" ± {(st.ci95_high - st.ci95_low) / 2:.2g}"
    return text


def write_aggregate_markdown(path: Path, table: Sequence[tuple[str, str, str, MetricStats]], title: str) -> None:
    """Metrics as rows, one column per scenario and setting: mean ± 95 % CI half-width (n seeds)."""
    columns: dict[tuple[str, str], dict[str, MetricStats]] = {}
    for scenario, setting, metric, st in table:
        columns.setdefault((scenario, setting), {})[metric] = st
    metrics: dict[str, None] = {}
    for cells in columns.values():
        metrics.update(dict.fromkeys(cells))
    seeds = {key: max((st.n for st in cells.values()), default=0) for key, cells in columns.items()}
    header = [f"{s} / {k} (n={seeds[(s, k)]})" for s, k in columns]
    lines = [f"# {title}", "",
             ("Mean ± half-width of the 95 % confidence interval of the mean over seeds (Student's t); "
              "safety and operational metrics side by side."), "",
             "| metric | " + " | ".join(header) + " |", "|---|" + "---|" * len(header)]
    for metric in metrics:
        row = [_cell(columns[key][metric]) if metric in columns[key] else "-" for key in columns]
        lines.append(f"| {metric} | " + " | ".join(row) + " |")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
