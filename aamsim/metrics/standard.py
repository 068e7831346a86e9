"""The standard AAM metrics (safety and operational), as defined in docs/metrics.md.

Normalisations: "per flight" divides by the number of flights in the run
(the paper's NMAC count normalised by the number of aircraft); "per flight
hour" divides by the total airborne time of all flights.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from aamsim.conflicts.separation import LOWC, NMAC
from aamsim.metrics.registry import AAM_VS_AAM, AAM_VS_REAL, MetricContext, MetricFn, MetricRegistry, MetricValue

if TYPE_CHECKING:
    from aamsim.traffic.traffic import FlightRecord


def _per_flight(count: int, ctx: MetricContext) -> float | None:
    return count / len(ctx.flights) if ctx.flights else None


def _per_hour(count: float, ctx: MetricContext) -> float | None:
    hours = ctx.flight_hours
    return count / hours if hours > 0 else None


def _mean(values: list[float]) -> float | None:
    return sum(values) / len(values) if values else None


def _flight_end_s(flight: FlightRecord, ctx: MetricContext) -> float:
    """When a flight's record ends: its deletion (arrived or not), else the end of the run."""
    return ctx.duration_s if math.isnan(flight.deleted_s) else flight.deleted_s


def _mean_delay_s(ctx: MetricContext) -> float | None:
    """End of each flight's record minus its scheduled arrival, over every scheduled flight that has one:
    flown (arrived or not, :func:`_flight_end_s`) and never departed (the end of the run)."""
    flown = [_flight_end_s(f, ctx) - f.scheduled_arrival_s for f in ctx.flights if not math.isnan(f.scheduled_arrival_s)]
    held = [ctx.duration_s - h.scheduled_arrival_s for h in ctx.not_departed if not math.isnan(h.scheduled_arrival_s)]
    return _mean(flown + held)


def _events(volume: str, per: str = "") -> MetricFn:
    def metric(ctx: MetricContext) -> MetricValue:
        count = len(ctx.events_of(volume))
        if per == "flight":
            return _per_flight(count, ctx)
        if per == "hour":
            return _per_hour(count, ctx)
        return count

    return metric


ENCOUNTERS = ("same-direction", "head-on", "crossing", "vertical", "hover")


def _events_by_encounter(volume: str, kind: str) -> MetricFn:
    return lambda ctx: ctx.encounter_counts(volume).get(kind, 0)


def _events_between(volume: str, kind: str) -> MetricFn:
    return lambda ctx: ctx.pair_kind_counts(volume).get(kind, 0)


def register_standard_metrics(reg: MetricRegistry) -> None:
    # ------------------------------------------------------------------ safety
    for vol in (NMAC, LOWC):  # the separation standard's volumes (aamsim.conflicts.separation)
        reg.add("safety", f"{vol}_events", _events(vol))
        reg.add("safety", f"{vol}_per_flight", _events(vol, per="flight"))
        reg.add("safety", f"{vol}_per_flight_hour", _events(vol, per="hour"))
    for vol in (NMAC, LOWC):  # the AAM events split by what the other aircraft is (real traffic overlays)
        reg.add("safety", f"{vol}_events_aam_vs_aam", _events_between(vol, AAM_VS_AAM))
        reg.add("safety", f"{vol}_events_aam_vs_real_traffic", _events_between(vol, AAM_VS_REAL))
    for kind in ENCOUNTERS:  # NMAC events by geometry at the closest point (docs/metrics.md)
        reg.add("safety", f"nmac_{kind.replace('-', '_')}", _events_by_encounter(NMAC, kind))
    reg.add("safety", "min_separation_m", lambda c: c.min_separation_m if math.isfinite(c.min_separation_m) else None)
    reg.add("safety", "time_in_lowc_s", lambda c: sum(e.duration_s(c.duration_s) for e in c.events_of(LOWC)))
    reg.add("safety", "conflict_pairs", lambda c: c.conflict_pairs)
    # ------------------------------------------------------------- operational
    reg.add("operational", "flights", lambda c: len(c.flights))
    reg.add("operational", "flights_completed", lambda c: c.count(lambda f: f.arrived))
    reg.add("operational", "flight_hours", lambda c: c.flight_hours)
    reg.add("operational", "alert_rate_per_flight_hour", lambda c: _per_hour(sum(f.advisories for f in c.flights), c))
    reg.add("operational", "advisories", lambda c: sum(f.advisories for f in c.flights))
    reg.add("operational", "airborne_holding_s", lambda c: sum(f.slow_s for f in c.flights))
    reg.add("operational", "holding_flight_share", lambda c: _per_flight(c.count(lambda f: f.slow_s > 0), c))
    reg.add("operational", "holding_speed_threshold_mps", lambda c: c.hold_speed_mps)
    reg.add("operational", "flights_unfinished", lambda c: c.count(lambda f: not f.arrived))
    # Scheduled flights a departure planner kept on the ground to the end (rejected, or not yet released):
    # no aircraft, so no flight record, yet the table must account for every scheduled flight:
    # completed + unfinished + not departed = scheduled.
    reg.add("operational", "flights_not_departed", lambda c: len(c.not_departed))
    reg.add("operational", "flights_scheduled", lambda c: len(c.flights) + len(c.not_departed))
    # Unfinished flights count, censored at the end of their record (deletion, else the end of the run):
    # counting arrived flights only made a policy that parks aircraft look fast (issue 28). For an
    # unfinished flight the figure is a lower bound of what it would have been. A flight that never
    # departed is late to the end of the run too (it has no flight time: it never flew).
    reg.add("operational", "mean_flight_time_s",
            lambda c: _mean([_flight_end_s(f, c) - f.created_s for f in c.flights]))
    reg.add("operational", "mean_delay_s", _mean_delay_s)
    reg.add("operational", "mean_flight_time_completed_s",
            lambda c: _mean([f.deleted_s - f.created_s for f in c.flights if f.arrived]))
    reg.add("operational", "mean_delay_completed_s",
            lambda c: _mean([f.deleted_s - f.scheduled_arrival_s for f in c.flights
                             if f.arrived and not math.isnan(f.scheduled_arrival_s)]))
    reg.add("operational", "distance_flown_m", lambda c: sum(f.distance_m for f in c.flights))
    reg.add("operational", "mean_distance_m", lambda c: _mean([f.distance_m for f in c.flights]))
    reg.add("operational", "throughput_per_hour",
            lambda c: c.count(lambda f: f.arrived) / (c.duration_s / 3600.0) if c.duration_s > 0 else None)
