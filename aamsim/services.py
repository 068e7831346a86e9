"""Built-in services attached to every ``aamsim run``: conflict detection and metrics."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from aamsim.conflicts.service import PAPER_VOLUMES, ConflictService
from aamsim.metrics.service import MetricsService, write_conflicts_csv

if TYPE_CHECKING:
    from aamsim.simulation import Simulation


def attach_run_services(sim: Simulation, cfg: Any) -> None:
    """Conflict detection and the metric groups of the run config; they write into the run directory."""
    volumes = tuple(getattr(cfg, "volumes", None) or PAPER_VOLUMES)
    conflicts = ConflictService(volumes=volumes)
    conflicts.attach(sim)
    metrics = MetricsService(groups=tuple(getattr(cfg, "metrics", ("safety", "operational"))))
    metrics.attach(sim)

    def finish(sim: Simulation, out_dir: Path, summary: dict[str, Any]) -> None:
        conflicts.finish(sim)
        summary["separation_volumes"] = {v.name: v.describe() for v in conflicts.volumes}
        summary.update(metrics.compute(sim))
        write_conflicts_csv(out_dir / "conflicts.csv", sim)

    sim.extensions.setdefault("run_outputs", []).append(finish)
