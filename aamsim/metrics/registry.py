"""Metric registry: named metrics in selectable groups (``safety``, ``operational``, ...).

Each simulation's metrics service owns a registry pre-filled with the
standard metrics; a plugin or a user adds one in a few lines::

    def hover_share(ctx):
        return ctx.count(lambda f: f.slow_s > 60) / max(1, len(ctx.flights))

    sim.services.metrics.registry.add("operational", "long_hover_share", hover_share)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from aamsim.conflicts.separation import PAPER_STANDARD, SeparationStandard

if TYPE_CHECKING:
    from aamsim.conflicts.service import SeparationEvent
    from aamsim.simapi import SimulationCore
    from aamsim.traffic.traffic import FlightRecord

MetricValue = float | int | None
MetricFn = Callable[["MetricContext"], MetricValue]


@dataclass(frozen=True)
class NotDeparted:
    """A scheduled flight that never took off: held on the ground (by a departure planner) until the run ended.

    It has no flight record (its aircraft was never created); the metrics count it beside the flights
    (``flights_not_departed``) and in the delay, to the end of the run, when it was due to depart before
    the run ended.
    """

    key: str  # the request's name: its callsign, "<callsign>#k" for its k-th flight
    scheduled_departure_s: float  # filed departure [s of sim time]
    scheduled_arrival_s: float = math.nan  # filed arrival (RTA at the destination) [s of sim time]; NaN: none


@dataclass
class MetricContext:
    """What a metric function may read: the flights, the separation events, the run."""

    sim: SimulationCore
    flights: list[FlightRecord]
    events: list[SeparationEvent]
    duration_s: float
    hold_speed_mps: float
    min_separation_m: float = math.inf
    conflict_pairs: int = 0
    real_traffic: frozenset[str] = frozenset()  # callsigns of replayed real aircraft (aamsim.realtraffic)
    not_departed: list[NotDeparted] = field(default_factory=list)  # scheduled flights never created
    # The volumes the safety metrics count (nmac_*, lowc_*): the conflict service's standard.
    separation: SeparationStandard = PAPER_STANDARD
    # Per volume, its events and their counts by encounter and by pair kind: a dense run has tens of
    # thousands of events and a dozen metrics reading them.
    _by_volume: dict[str, list[SeparationEvent]] = field(default_factory=dict, init=False, repr=False,
                                                         compare=False)
    _counts: dict[tuple[str, str], dict[str, int]] = field(default_factory=dict, init=False, repr=False,
                                                           compare=False)

    def pair_kind(self, event: SeparationEvent) -> str:
        """``AAM vs AAM``, ``AAM vs real traffic`` or ``real vs real traffic`` (:func:`pair_kind`)."""
        return pair_kind(event.ac1, event.ac2, self.real_traffic)

    @property
    def flight_hours(self) -> float:
        return sum(f.airborne_s for f in self.flights) / 3600.0

    def count(self, predicate: Callable[[FlightRecord], bool]) -> int:
        return sum(1 for f in self.flights if predicate(f))

    def events_of(self, volume: str) -> list[SeparationEvent]:
        found = self._by_volume.get(volume)
        if found is None:
            found = self._by_volume[volume] = [e for e in self.events if e.volume == volume]
        return list(found)

    def encounter_counts(self, volume: str) -> dict[str, int]:
        """Events of ``volume`` by encounter geometry (``SeparationEvent.encounter``)."""
        return self._count(volume, "encounter", lambda e: e.encounter)

    def pair_kind_counts(self, volume: str) -> dict[str, int]:
        """Events of ``volume`` by :meth:`pair_kind`."""
        return self._count(volume, "pair", self.pair_kind)

    def _count(self, volume: str, what: str, key: Callable[[SeparationEvent], str]) -> dict[str, int]:
        counts = self._counts.get((volume, what))
        if counts is None:
            counts = self._counts[(volume, what)] = {}
            for e in self.events_of(volume):
                k = key(e)
                counts[k] = counts.get(k, 0) + 1
        return counts


AAM_VS_AAM, AAM_VS_REAL, REAL_VS_REAL = "AAM vs AAM", "AAM vs real traffic", "real vs real traffic"


def pair_kind(ac1: str, ac2: str, real_traffic: frozenset[str] | set[str]) -> str:
    """Which traffic an encounter is between: AAM aircraft, replayed real aircraft, or one of each."""
    real = (ac1 in real_traffic) + (ac2 in real_traffic)
    return (AAM_VS_AAM, AAM_VS_REAL, REAL_VS_REAL)[real]


@dataclass
class MetricRegistry:
    groups: dict[str, dict[str, MetricFn]] = field(default_factory=dict)

    def add(self, group: str, name: str, fn: MetricFn) -> None:
        metrics = self.groups.setdefault(group, {})
        if name in metrics:
            raise ValueError(f"metric {group}.{name} is already registered")
        metrics[name] = fn

    def names(self) -> dict[str, list[str]]:
        return {g: list(m) for g, m in self.groups.items()}

    def compute(self, groups: Iterable[str], ctx: MetricContext) -> dict[str, dict[str, Any]]:
        out: dict[str, dict[str, Any]] = {}
        for group in groups:
            if group not in self.groups:
                raise KeyError(f"unknown metric group {group!r}; known: {', '.join(sorted(self.groups))}")
            values: dict[str, Any] = {}
            for name, fn in self.groups[group].items():
                value = fn(ctx)
                if isinstance(value, float) and not math.isfinite(value):
                    value = None
                values[name] = value
            out[group] = values
        return out
