"""Every scheduled flight is accounted for: a flight a departure planner kept on the ground to the end counts.

The reference-scores table showed a hierarchical planner that rejected all 678 requests with 0 flights
completed, 0 unfinished and no delay: the metrics counted flight records only, and a flight that never
took off has none. Now ``flights_not_departed`` counts them, ``flights_scheduled`` = completed +
unfinished + not departed, and their delay runs to the end of the episode, as an unfinished airborne
flight's does.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from aamsim import Simulation
from aamsim.metrics.registry import MetricContext
from aamsim.traffic.traffic import FlightRecord
from rlbridge.agents.rollout import EnvSpec, RolloutWorker
from rlbridge.core import EpisodeCore
from rlbridge.usecases import available

RTA = str(Path(__file__).parent / "data" / "strategic_rta.scn")
NO_LAYERS = {"layers_ft": [], "max_delay_slots": 2}  # actions: delay 0, 60, 120 s; 3 = reject
REJECT = 3
FILED = {"N1": 10.0, "N2": 10.0, "L1": 400.0}  # departure requests of strategic_rta.scn [s]
PLANNERS = ("strategic_planning", "hierarchical")


def _operational(core: EpisodeCore) -> dict:
    return core.metrics()["operational"]


def _play(core: EpisodeCore, actions: list[int], seed: int = 1) -> dict:
    """One planner episode deciding the requests in order with ``actions``; its operational metrics."""
    result = core.reset(seed)
    todo = list(actions)
    while not result.done:
        result = core.step({"planner": todo.pop(0)} if todo and result.agents else {})
    return _operational(core)


def test_flights_never_departed_are_counted_beside_the_flights_and_late_to_the_end_hand_computed():
    from aamsim.metrics import NotDeparted

    sim = Simulation(seed=1)
    flights = [FlightRecord("ARR", "EC35", 0.0, deleted_s=600.0, arrived=True, scheduled_arrival_s=500.0),
               FlightRecord("FLY", "EC35", 100.0, scheduled_arrival_s=700.0)]  # still flying at 1,000 s
    held = [NotDeparted("GND", 200.0, 400.0), NotDeparted("GND#2", 300.0)]  # the second has no scheduled arrival
    ctx = MetricContext(sim=sim, flights=flights, events=[], duration_s=1000.0, hold_speed_mps=2.57,
                        not_departed=held)
    op = sim.services.start().metrics.registry.compute(("operational",), ctx)["operational"]
    assert (op["flights"], op["flights_completed"], op["flights_unfinished"]) == (2, 1, 1)
    assert (op["flights_not_departed"], op["flights_scheduled"]) == (2, 4)
    # Delays 600 - 500, 1,000 - 700 (flying at the end) and 1,000 - 400 (on the ground at the end).
    assert op["mean_delay_s"] == pytest.approx((100 + 300 + 600) / 3)
    assert op["mean_flight_time_s"] == pytest.approx((600 + 900) / 2)  # never flown: no flight time
    assert op["mean_delay_completed_s"] == pytest.approx(100.0)


def test_a_planner_that_rejects_every_request_leaves_every_flight_not_departed_and_late():
    core = EpisodeCore(RTA, "strategic_planning", NO_LAYERS, time_limit_s=100.0)
    op = _play(core, [REJECT] * 3)
    # N1 and N2 were due at 10 s and never left; L1 was filed for 400 s, after the end: not counted.
    assert (op["flights"], op["flights_completed"], op["flights_unfinished"]) == (0, 0, 0)
    assert (op["flights_not_departed"], op["flights_scheduled"]) == (2, 2)
    assert op["mean_delay_s"] == pytest.approx(100.0 - 60.0)  # both scheduled to arrive at 60 s
    # Without a time limit all three requests are decided (rejected); the end of the episode is their clock.
    core = EpisodeCore(RTA, "strategic_planning", NO_LAYERS)
    op = _play(core, [REJECT] * 3)
    end = core.sim.simt
    assert end > 400.0 and (op["flights_not_departed"], op["flights_scheduled"]) == (3, 3)
    assert op["mean_delay_s"] == pytest.approx(((end - 60.0) * 2 + end - 450.0) / 3)


def test_a_flight_released_after_the_end_is_not_departed_and_one_flying_is_unfinished():
    # N1 leaves on time (arrives after about 106 s of flight), N2 two slots late (130 s): at 120 s N2 is
    # still on the ground.
    core = EpisodeCore(RTA, "strategic_planning", NO_LAYERS, time_limit_s=120.0)
    op = _play(core, [0, 2])
    arrival = {f.acid: f.deleted_s for f in core.sim.flight_log}
    assert set(arrival) == {"N1"} and 110.0 < arrival["N1"] < 120.0
    assert (op["flights_completed"], op["flights_unfinished"], op["flights_not_departed"]) == (1, 0, 1)
    assert op["mean_delay_s"] == pytest.approx(((arrival["N1"] - 60.0) + (120.0 - 60.0)) / 2)
    # Ended at 60 s instead: N1 is airborne (unfinished), N2 on the ground (not departed), both 0 s late.
    core = EpisodeCore(RTA, "strategic_planning", NO_LAYERS, time_limit_s=60.0)
    op = _play(core, [0, 2])
    assert (op["flights_completed"], op["flights_unfinished"], op["flights_not_departed"]) == (0, 1, 1)
    assert op["mean_delay_s"] == pytest.approx(0.0)


def _contenders(usecase: str) -> list[str]:
    from rlbridge.experiment.scores import usecase_contenders

    reference, others, _ = usecase_contenders(usecase)
    return [reference, *others]


def _scheduled_before(end_s: float) -> int:
    """The scenario's flights filed to depart before ``end_s`` (read from the file, not from the metrics)."""
    return sum(1 for t in FILED.values() if t < end_s)


@pytest.mark.parametrize("time_limit_s", [None, 100.0])
@pytest.mark.parametrize("usecase", available())
def test_completed_unfinished_and_not_departed_add_up_to_the_scheduled_flights(usecase, time_limit_s):
    """The invariant of the reference-scores table, for every use case and every contender of its row set."""
    params = {"planning": NO_LAYERS} if usecase == "hierarchical" else NO_LAYERS if usecase in PLANNERS else {}
    spec = EnvSpec(RTA, usecase, params, time_limit_s=time_limit_s)
    kinds = _contenders(usecase)
    worker = RolloutWorker(spec, {k: {"kind": k} for k in kinds})
    episodes = {k: worker.collect([3], actor=k, record=False)[0] for k in kinds}
    if usecase in PLANNERS:  # and a planner that keeps everything on the ground
        core = spec.make()
        _play(core, [REJECT] * 3, seed=3)
        episodes["reject"] = type("Stats", (), {"metrics": core.metrics(), "sim_s": core.sim.simt})()
    for kind, stats in episodes.items():
        op = stats.metrics["operational"]
        scheduled = _scheduled_before(stats.sim_s)
        assert op["flights_completed"] + op["flights_unfinished"] + op["flights_not_departed"] == scheduled, kind
        assert op["flights_scheduled"] == scheduled, kind
        if time_limit_s is None and kind == "reject":
            assert op["flights_not_departed"] == 3 and not math.isnan(op["mean_delay_s"])


def test_the_reward_per_scheduled_flight_of_a_planner_that_keeps_all_on_the_ground():
    """The scores table divides by the scheduled flights: 'per aircraft' of no aircraft was -678 per episode."""
    from rlbridge.experiment.scores import episode_row

    summary = {"flights_created": 1, "reward_total": -678.0,
               "operational": {"flights": 0, "flights_completed": 0, "flights_unfinished": 0,
                               "flights_not_departed": 678, "flights_scheduled": 678}}
    row = episode_row(summary, "here")
    assert row["reward_per_aircraft"] == pytest.approx(-1.0)
    assert row["operational.flights_not_departed"] == 678.0


def test_the_scores_table_refuses_a_planner_episode_that_does_not_account_for_its_flights():
    from rlbridge.experiment.scores import episode_row

    stale = {"flights_created": 1, "reward_total": -678.0, "hierarchical": {"requests": 678, "unplaced": 678},
             "operational": {"flights": 0, "flights_completed": 0, "flights_unfinished": 0}}
    with pytest.raises(ValueError, match="here: 0 completed \\+ 0 unfinished .* 678 requests"):
        episode_row(stale, "here")
    # A use case that holds no departure back has none (episodes recorded before the column existed).
    flown = {"flights_created": 678, "reward_total": 67.8,
             "operational": {"flights": 678, "flights_completed": 677, "flights_unfinished": 1}}
    row = episode_row(flown, "here")
    assert row["operational.flights_not_departed"] == 0.0 and row["reward_per_aircraft"] == pytest.approx(0.1)


def test_a_frozen_planner_under_learning_aircraft_counts_its_held_flights_too():
    # train="tactical": the frozen FCFS planner gives N2 one slot (it departs at 70 s, N1 at 10 s on its
    # path); at 60 s N1 is airborne and N2 still on the ground.
    core = EpisodeCore(RTA, "hierarchical", {"train": "tactical", "planner": "fcfs", "planning": NO_LAYERS},
                       time_limit_s=60.0)
    result = core.reset(1)
    while not result.done:
        result = core.step({a: 1 for a in result.alive})
    op = _operational(core)
    assert (op["flights_completed"], op["flights_unfinished"], op["flights_not_departed"]) == (0, 1, 1)
    assert op["mean_delay_s"] == pytest.approx(0.0)  # both were due at 60 s


def test_a_contender_whose_every_episode_gave_the_same_figures_is_told_apart():
    from rlbridge.experiment.scores import same_every_episode

    a = {"safety.nmac_events": 227.0, "operational.mean_delay_s": 267.57}
    assert same_every_episode([a, dict(a), dict(a)])
    assert not same_every_episode([a, {**a, "safety.nmac_events": 226.0}])
    assert not same_every_episode([a])  # one episode: nothing to compare
