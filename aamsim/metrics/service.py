"""Metrics of a simulation: computes the registered metric groups and writes conflicts.csv."""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from math import isfinite, isnan
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aamsim.conflicts.events import classify_encounter, track_speed
from aamsim.conflicts.service import conflicts_of
from aamsim.metrics.registry import MetricContext, MetricRegistry, pair_kind
from aamsim.metrics.standard import register_standard_metrics

if TYPE_CHECKING:
    from aamsim.conflicts.events import SeparationEvent
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

    def context(self, sim: Simulation, events: list[SeparationEvent] | None = None) -> MetricContext:
        """The run's AAM flights and the events with at least one AAM aircraft in them (two replayed
        real aircraft meeting are not an AAM event; conflicts.csv lists them, marked).

        ``events``: the conflict service's events when the caller has them already (they take a
        while to build in a dense run)."""
        service = conflicts_of(sim)
        real = real_traffic_callsigns(sim)
        if events is None:
            events = service.events
        return MetricContext(
            sim=sim,
            flights=list(sim.flights()),
            events=[e for e in events if not (e.ac1 in real and e.ac2 in real)] if real else list(events),
            real_traffic=real,
            duration_s=sim.simt,
            hold_speed_mps=sim.settings.hold_speed_mps,
            min_separation_m=service.min_separation_m,
            conflict_pairs=service.conflict_pairs_total,
        )

    def compute(self, sim: Simulation, groups: tuple[str, ...] | None = None,
                events: list[SeparationEvent] | None = None) -> dict[str, dict[str, Any]]:
        return self.registry.compute(groups or self.groups, self.context(sim, events))


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


def _num1(x: float) -> str:
    return f"{x:.1f}" if isfinite(x) else ""


def _num2(x: float) -> str:
    return f"{x:.2f}" if isfinite(x) else ""


def _num7(x: float) -> str:
    return f"{x:.7f}" if isfinite(x) else ""


def write_conflicts_csv(path: Path, sim: Simulation, events: list[SeparationEvent] | None = None) -> int:
    """Every event of every volume; ``pair`` says AAM vs AAM, AAM vs real traffic or real vs real traffic.

    ``events``: the conflict service's events when the caller has them already."""
    if events is None:
        events = conflicts_of(sim).events
    real = real_traffic_callsigns(sim)
    rows = []
    for e in sorted(events, key=lambda ev: (ev.start_s, ev.volume, ev.ac1, ev.ac2)):
        motion = (*track_speed(e.vel1), *track_speed(e.vel2))
        trk1, gs1, vs1, trk2, gs2, vs2 = motion
        (lat1, lon1, alt1), (lat2, lon2, alt2) = e.pos1, e.pos2
        known = not any(isnan(x) for x in e.vel1 + e.vel2)  # as SeparationEvent.encounter, sparing a recompute
        rows.append((e.volume, e.ac1, e.ac2, _num2(e.start_s), _num2(e.end_s), _num2(e.min_dist_m), _num2(e.t_min_s),
                     _num7(lat1), _num7(lon1), _num2(alt1), _num7(lat2), _num7(lon2), _num2(alt2),
                     _num1(trk1), _num2(gs1), _num2(vs1), _num1(trk2), _num2(gs2), _num2(vs2),
                     classify_encounter(*motion) if known else "", pair_kind(e.ac1, e.ac2, real)))
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(CONFLICT_COLUMNS)
        writer.writerows(rows)
    return len(events)
