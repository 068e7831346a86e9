"""Per-episode statistics carry the metrics the use case declares (issue 29), whatever the use case.

``EpisodeStats`` had only the corridor's separation counts as fields; now ``declared`` maps every
metric the use case's spec declares (its learning-curve columns' and its ``extra_metrics``) to the
episode's value. The separation fields stay: the evaluation's files are written from them.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

from rlbridge.agents.rollout import EnvSpec, EpisodeStats, RolloutWorker
from rlbridge.usecases import usecase_spec

DATA = Path(__file__).parent / "data"


def test_a_spec_declares_its_curve_metrics_then_its_extra_metrics_each_once():
    assert usecase_spec("reach_destination").declared_metrics("reach_destination") == (
        "reach_destination.arrivals", "safety.nmac_events", "safety.lowc_events", "reach_destination.flights_ended")
    assert usecase_spec("corridor_sa").declared_metrics("corridor_sa") == ("safety.nmac_events",
                                                                           "safety.lowc_events")
    planning = usecase_spec("strategic_planning").declared_metrics("strategic_planning")
    assert planning[:5] == ("strategic_planning.mean_delay_s", "strategic_planning.unplaced",
                            "strategic_planning.intent_conflicts", "safety.nmac_events", "safety.lowc_events")
    assert "strategic_planning.throughput_per_hour" in planning and len(planning) == len(set(planning))


def test_reach_destinations_declared_metrics_reach_the_episode_statistics():
    worker = RolloutWorker(EnvSpec(str(DATA / "tiny_conflict.scn"), "reach_destination", {}, time_limit_s=300.0),
                           {"policy": {"kind": "unequipped"}})
    stats = worker.collect([0], record=False)[0]
    assert list(stats.declared) == ["reach_destination.arrivals", "safety.nmac_events", "safety.lowc_events",
                                    "reach_destination.flights_ended"]
    extra = stats.metrics["reach_destination"]
    assert stats.declared["reach_destination.arrivals"] == extra["arrivals"]
    assert stats.declared["reach_destination.flights_ended"] == extra["flights_ended"]
    assert 0 <= stats.declared["reach_destination.arrivals"] <= stats.aircraft
    # The separation fields (the evaluation's columns) are the same counts.
    assert stats.declared["safety.nmac_events"] == stats.nmac_events
    assert stats.declared["safety.lowc_events"] == stats.lowc_events


def test_strategic_plannings_declared_metrics_reach_the_episode_statistics():
    worker = RolloutWorker(EnvSpec(str(DATA / "strategic_cross.scn"), "strategic_planning", {}, time_limit_s=900.0),
                           {"policy": {"kind": "fcfs"}})
    stats = worker.collect([0], record=False)[0]
    extra = stats.metrics["strategic_planning"]
    assert stats.declared == {path: (stats.metrics["safety"] if path.startswith("safety.") else extra)[
        path.split(".", 1)[1]] for path in usecase_spec("strategic_planning").declared_metrics("strategic_planning")}
    assert stats.declared["strategic_planning.flights_planned"] == extra["flights_planned"] > 0


def test_statistics_cached_before_the_field_still_load():
    stats = EpisodeStats(0, "x", "", 2, 5, 1.0, 0.5, 1, 2, 10.0, 0.1, env_steps=3,
                         declared={"safety.nmac_events": 1, "x.delays_s": [1.5, 2.0], "x.mean_m": None})
    assert EpisodeStats(**json.loads(json.dumps(asdict(stats)))) == stats
    old = {k: v for k, v in asdict(stats).items() if k != "declared"}  # an evaluation cache written before
    assert EpisodeStats(**old).declared == {}
