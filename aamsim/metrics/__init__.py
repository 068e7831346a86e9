"""Standardised AAM metrics: safety (NMAC, LoWC, separation) and operational groups."""

from aamsim.metrics.compare import Comparison, ComparisonError, compare_runs, expand_runs, load_run
from aamsim.metrics.registry import MetricContext, MetricRegistry, NotDeparted
from aamsim.metrics.service import MetricsService, record_advisories, record_advisory, write_conflicts_csv

__all__ = [
    "Comparison",
    "ComparisonError",
    "MetricContext",
    "MetricRegistry",
    "MetricsService",
    "NotDeparted",
    "compare_runs",
    "expand_runs",
    "load_run",
    "record_advisories",
    "record_advisory",
    "write_conflicts_csv",
]
