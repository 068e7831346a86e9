"""``aamsim batch``: many scenarios x settings x seeds in parallel (Ray), one run directory each, and
an aggregate table.

    aamsim batch scn/demo.scn my_batch.scn --seeds 5 --set lowc=450 --set lowc=600 --out runs/study

writes ``runs/study/<scenario>/<setting>/seed-<k>/`` (the files of ``aamsim run``), ``runs.csv`` (one row
per run), ``aggregate.csv`` (mean, std, 95 % CI per scenario, setting and metric) and ``aggregate.md``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aamsim.batch.aggregate import (
    RunRow,
    aggregate,
    flatten_metrics,
    write_aggregate_csv,
    write_aggregate_markdown,
    write_runs_csv,
)
from aamsim.batch.execute import JobResult, run_on_ray, run_serial
from aamsim.batch.plan import BatchError, BatchJob, ScenarioSource, Setting, load_sources, parse_settings, plan_jobs

__all__ = ["BatchError", "BatchJob", "BatchResult", "ScenarioSource", "Setting", "load_sources", "parse_settings",
           "plan_jobs", "run_batch"]


@dataclass
class BatchResult:
    out_dir: Path
    rows: list[RunRow]
    failed: int


def run_batch(jobs: Sequence[BatchJob], out_dir: Path, *, use_ray: bool = True, address: str | None = None,
              workers: int | None = None, on_result: Callable[[JobResult], None] | None = None,
              on_started: Callable[[dict[str, Any]], None] | None = None) -> BatchResult:
    """Run the jobs, write every run directory and the batch tables under ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    results = run_on_ray(jobs, address, workers, on_started) if use_ray else run_serial(jobs)
    rows: dict[int, RunRow] = {}
    for result in results:
        job = jobs[result.index]
        run_dir = out_dir / job.relpath
        if result.summary is not None:
            run_dir.mkdir(parents=True, exist_ok=True)
            for name, data in result.files.items():
                (run_dir / Path(name).name).write_bytes(data)
        rows[result.index] = RunRow(job.source.name, job.setting.label, job.seed, result.node, result.wall_s,
                                    job.relpath, result.error,
                                    flatten_metrics(result.summary) if result.summary else {})
        if on_result is not None:
            on_result(result)
    ordered = [rows[k] for k in sorted(rows)]  # the plan's order, whatever order they finished in
    write_runs_csv(out_dir / "runs.csv", ordered)
    table = aggregate(ordered)
    write_aggregate_csv(out_dir / "aggregate.csv", table)
    write_aggregate_markdown(out_dir / "aggregate.md", table, f"Batch {out_dir.name}")
    plan = [{"run_dir": j.relpath, "scenario": j.source.name, "file": j.source.path.name, "setting": j.setting.label,
             "seed": j.seed} for j in jobs]
    (out_dir / "batch.json").write_text(json.dumps({"runs": plan}, indent=2) + "\n", encoding="utf-8")
    return BatchResult(out_dir, ordered, sum(1 for r in ordered if r.error))
