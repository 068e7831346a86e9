"""Metric registry: named metrics in selectable groups (``safety``, ``operational``, ...).

Each simulation's metrics service owns a registry pre-filled with the
standard metrics; a plugin or a user adds one in a few lines::

    from aamsim.metrics import metrics_of

    def hover_share(ctx):
        return ctx.count(lambda f: f.slow_s > 60) / max(1, len(ctx.flights))

    metrics_of(sim).registry.add("operational", "long_hover_share", hover_share)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aamsim.conflicts.service import SeparationEvent
    from aamsim.simulation import Simulation
    from aamsim.traffic.traffic import FlightRecord

MetricValue = float | int | None
MetricFn = Callable[["MetricContext"], MetricValue]


@dataclass
class MetricContext:
    """What a metric function may read: the flights, the separation events, the run."""

    sim: Simulation
    flights: list[FlightRecord]
    events: list[SeparationEvent]
    duration_s: float
    hold_speed_mps: float
    min_separation_m: float = math.inf
    conflict_pairs: int = 0
    real_traffic: frozenset[str] = frozenset()  # callsigns of replayed real aircraft (aamsim.realtraffic)

    def pair_kind(self, event: SeparationEvent) -> str:
        """``AAM vs AAM``, ``AAM vs real traffic`` or ``real vs real traffic`` (:func:`pair_kind`)."""
        return pair_kind(event.ac1, event.ac2, self.real_traffic)

    @property
    def flight_hours(self) -> float:
        return sum(f.airborne_s for f in self.flights) / 3600.0

    def count(self, predicate: Callable[[FlightRecord], bool]) -> int:
        return sum(1 for f in self.flights if predicate(f))

    def events_of(self, volume: str) -> list[SeparationEvent]:
        return [e for e in self.events if e.volume == volume]


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
