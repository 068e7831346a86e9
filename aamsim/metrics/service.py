"""Metrics of a simulation: computes the registered metric groups and writes conflicts.csv."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aamsim.conflicts.events import track_speed
from aamsim.conflicts.service import conflicts_of
from aamsim.metrics.registry import MetricContext, MetricRegistry, pair_kind
from aamsim.metrics.standard import register_standard_metrics

if TYPE_CHECKING:
    from aamsim.simulation import Simulation

DEFAULT_GROUPS = ("safety", "operational")
CONFLICT_COLUMNS = ["volume", "ac1", "ac2", "start_s", "end_s", "min_dist_m", "t_min_s",
                    "lat1", "lon1", "alt1_m", "lat2", "lon2", "alt2_m",
                    "trk1_deg", "gs1_mps", "vs1_mps", "trk2_deg", "gs2_mps", "vs2_mps", "encounter", "pair"]


def _standard_registry() -> MetricRegistry:
    reg = MetricRegistry()
    register_standard_metrics(reg)
    return reg


@dataclass
class MetricsService:
    groups: tuple[str, ...] = DEFAULT_GROUPS
    registry: MetricRegistry = field(default_factory=_standard_registry)

    def context(self, sim: Simulation) -> MetricContext:
        """The run's AAM flights and the events with at least one AAM aircraft in them (two replayed
        real aircraft meeting are not an AAM event; conflicts.csv lists them, marked)."""
        service = conflicts_of(sim)
        real = real_traffic_callsigns(sim)
        return MetricContext(
            sim=sim,
            flights=list(sim.flights()),
            events=[e for e in service.events if not (e.ac1 in real and e.ac2 in real)],
            real_traffic=real,
            duration_s=sim.simt,
            hold_speed_mps=sim.settings.hold_speed_mps,
            min_separation_m=service.min_separation_m,
            conflict_pairs=service.conflict_pairs_total,
        )

    def compute(self, sim: Simulation, groups: tuple[str, ...] | None = None) -> dict[str, dict[str, Any]]:
        return self.registry.compute(groups or self.groups, self.context(sim))


def metrics_of(sim: Simulation) -> MetricsService:
    """The metrics service of a simulation (``sim.services.metrics``; see :mod:`aamsim.services`)."""
    return sim.require_services().metrics


def record_advisory(sim: Simulation, acid: str, action: str) -> None:
    """Count an advisory given to an aircraft; ``hold`` advisories are not alerts."""
    if action.lower() == "hold":
        return
    i = sim.traffic.find(acid)
    if i is not None:
        sim.traffic.flights[i].advisories += 1


def real_traffic_callsigns(sim: Simulation) -> frozenset[str]:
    """Callsigns of every replayed real aircraft of the run (flying or gone)."""
    return frozenset(rec.acid for rec in sim.flights(real_traffic=True))


def write_conflicts_csv(path: Path, sim: Simulation) -> int:
    """Every event of every volume; ``pair`` says AAM vs AAM, AAM vs real traffic or real vs real traffic."""
    events = conflicts_of(sim).events
    real = real_traffic_callsigns(sim)

    def num(x: float, d: int) -> str:
        return "" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.{d}f}"

    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(CONFLICT_COLUMNS)
        for e in sorted(events, key=lambda ev: (ev.start_s, ev.volume, ev.ac1, ev.ac2)):
            motion = [num(x, d) for vel in (e.vel1, e.vel2) for x, d in zip(track_speed(vel), (1, 2, 2))]
            writer.writerow([e.volume, e.ac1, e.ac2, num(e.start_s, 2), num(e.end_s, 2), num(e.min_dist_m, 2),
                             num(e.t_min_s, 2), num(e.pos1[0], 7), num(e.pos1[1], 7), num(e.pos1[2], 2),
                             num(e.pos2[0], 7), num(e.pos2[1], 7), num(e.pos2[2], 2), *motion, e.encounter,
                             pair_kind(e.ac1, e.ac2, real)])
    return len(events)
