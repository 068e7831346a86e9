"""Metrics of a simulation: computes the registered metric groups and writes conflicts.csv."""

from __future__ import annotations

import csv
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from math import isfinite, isnan
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.conflicts.events import classify_encounter, track_speed
from aamsim.conflicts.separation import PAPER_STANDARD, SeparationStandard
from aamsim.conflicts.service import ConflictService
from aamsim.metrics.registry import MetricContext, MetricRegistry, NotDeparted, pair_kind
from aamsim.metrics.standard import register_standard_metrics
from aamsim.output.fastcsv import format_csv_table

if TYPE_CHECKING:
    from aamsim.conflicts.events import SeparationEvent
    from aamsim.simapi import SimulationCore

DEFAULT_GROUPS = ("safety", "operational")
CONFLICT_COLUMNS = ["volume", "ac1", "ac2", "start_s", "end_s", "min_dist_m", "t_min_s",
                    "lat1", "lon1", "alt1_m", "lat2", "lon2", "alt2_m",
                    "trk1_deg", "gs1_mps", "vs1_mps", "trk2_deg", "gs2_mps", "vs2_mps", "encounter", "pair"]


def _standard_registry() -> MetricRegistry:
    reg = MetricRegistry()
    register_standard_metrics(reg)
    return reg


def _standard_or_default(service: ConflictService) -> SeparationStandard:
    """The service's separation standard; the paper's when its volumes have no ``nmac``/``lowc`` (custom sets)."""
    try:
        return service.standard
    except LookupError:
        return PAPER_STANDARD


@dataclass
class MetricsService:
    groups: tuple[str, ...] = DEFAULT_GROUPS
    # The simulation's conflict service, whose events and separation the metrics count (aamsim.services).
    conflicts: ConflictService = field(default_factory=ConflictService)
    registry: MetricRegistry = field(default_factory=_standard_registry)
    # Who holds scheduled departures back (a departure planner) tells which flights it kept on the ground:
    # they have no flight record, yet every scheduled flight must be counted (issue 28). None: nobody does.
    held_departures: Callable[[], Sequence[NotDeparted]] | None = None

    def context(self, sim: SimulationCore, events: list[SeparationEvent] | None = None) -> MetricContext:
        """The run's AAM flights and the events with at least one AAM aircraft in them (two replayed
        real aircraft meeting are not an AAM event; conflicts.csv lists them, marked).

        ``events``: the conflict service's events when the caller has them already (they take a
        while to build in a dense run)."""
        service = self.conflicts
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
            separation=_standard_or_default(service),
            not_departed=self.not_departed(sim),
        )

    def not_departed(self, sim: SimulationCore) -> list[NotDeparted]:
        """The held flights that were due to depart before now: a flight filed to depart after the end of the
        run is not late (an unplanned run does not create it either)."""
        if self.held_departures is None:
            return []
        return [h for h in self.held_departures() if h.scheduled_departure_s < sim.simt]

    def compute(self, sim: SimulationCore, groups: tuple[str, ...] | None = None,
                events: list[SeparationEvent] | None = None) -> dict[str, dict[str, Any]]:
        return self.registry.compute(groups or self.groups, self.context(sim, events))


def record_advisory(sim: SimulationCore, acid: str, action: str) -> None:
    """Count an advisory given to an aircraft; ``hold`` advisories are not alerts."""
    if action.lower() == "hold":
        return
    i = sim._traffic.find(acid)
    if i is not None:
        record_advisories(sim, (i,), (action,))


def record_advisories(sim: SimulationCore, slots: Sequence[int], actions: Sequence[str]) -> None:
    """:func:`record_advisory` for the aircraft in ``slots`` (one action each), by slot: a use case that
    advises many aircraft per decision has their slots already."""
    flights = sim._traffic.flights
    at = f" at {sim.simt:.0f} s"
    for i, action in zip(slots, actions):
        if action.lower() == "hold":
            continue
        flight = flights[i]
        flight.advisories += 1
        flight.last_advisory = action + at


def real_traffic_callsigns(sim: SimulationCore) -> frozenset[str]:
    """Callsigns of every replayed real aircraft of the run (flying or gone)."""
    return frozenset(rec.acid for rec in sim.flights(real_traffic=True))


# Decimals of the numeric columns of conflicts.csv, in column order (after volume, ac1, ac2).
_DECIMALS = (2, 2, 2, 2, 7, 7, 2, 7, 7, 2, 1, 2, 2, 1, 2, 2)


def _column(values: list[float], decimals: int) -> list[str]:
    """Fixed-point text of a column; empty where not finite. (Column by column: a dense run has tens of
    thousands of events, and one comprehension per column costs far less than a call per cell.)"""
    spec = f".{decimals}f"
    return [format(x, spec) if isfinite(x) else "" for x in values]


def write_conflicts_csv(path: Path, sim: SimulationCore, events: list[SeparationEvent]) -> int:
    """Every event of every volume; ``pair`` says AAM vs AAM, AAM vs real traffic or real vs real traffic.

    ``events``: the conflict service's events (``sim.services.conflicts.events``)."""
    real = real_traffic_callsigns(sim)
    ordered = sorted(events, key=lambda ev: (ev.start_s, ev.volume, ev.ac1, ev.ac2))
    numbers: list[tuple[float, ...]] = []
    encounters: list[str] = []
    for e in ordered:
        motion = (*track_speed(e.vel1), *track_speed(e.vel2))
        numbers.append((e.start_s, e.end_s, e.min_dist_m, e.t_min_s, *e.pos1, *e.pos2, *motion))
        known = not any(isnan(x) for x in e.vel1 + e.vel2)  # as SeparationEvent.encounter, sparing a recompute
        encounters.append(classify_encounter(*motion) if known else "")
    lead = [(e.volume, e.ac1, e.ac2) for e in ordered]
    trail = [(kind, pair_kind(e.ac1, e.ac2, real)) for e, kind in zip(ordered, encounters)]
    # The compiled writer gives the csv module's bytes (Python's rounding, tested). Formatting cell by cell
    # in Python was about 40 % of this function (12,296 events at N = 1,000, cProfile). Texts that need
    # quoting, or numbers too wide for it, go through the csv module.
    table = format_csv_table(lead, np.array(numbers, dtype=np.float64).T, _DECIMALS, trail) if numbers else b""
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(CONFLICT_COLUMNS)
        if table is not None:
            fh.write(table.decode("utf-8"))
        else:  # (no events give an empty table, never None)
            columns = [_column(list(col), d) for col, d in zip(zip(*numbers), _DECIMALS)]
            writer.writerows((*head, *cells, *tail) for head, cells, tail in zip(lead, zip(*columns), trail))
    return len(events)
