"""Intervals that fit their sample size (issue 28): Student's t, over training runs, on a fixed support.

Before: learning-curve bands used z = 1.96 with 2 seeds (t with 1 degree of freedom is 12.71), the band
switched from across-runs to within-run where one run stopped early, and ratios had no interval over
training seeds.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from aamsim.batch.aggregate import describe
from aamsim.metrics.stats import mean_interval, t_critical
from rlbridge.experiment.report import TrainRun, band, ratio_interval


@pytest.mark.parametrize(("dof", "table"), [(1, 12.706), (2, 4.303), (3, 3.182), (4, 2.776), (9, 2.262),
                                            (30, 2.042), (100, 1.984)])
def test_t_quantiles_match_the_published_table(dof: int, table: float):
    assert t_critical(dof) == pytest.approx(table, abs=5e-4)


@given(st.integers(1, 400), st.floats(0.5, 0.999))
def test_the_t_quantile_exceeds_the_normal_one_and_shrinks_with_more_samples(dof: int, confidence: float):
    z = math.sqrt(2) * _erfinv(confidence)
    assert t_critical(dof, confidence) > z
    assert t_critical(dof + 1, confidence) < t_critical(dof, confidence)


def _erfinv(p: float) -> float:
    lo, hi = 0.0, 10.0
    for _ in range(100):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if math.erf(mid) < p else (lo, mid)
    return (lo + hi) / 2


def test_two_samples_get_the_t_interval_not_the_normal_one():
    mi = mean_interval([1.0, 3.0])
    assert mi is not None and mi.mean == 2.0 and mi.std == pytest.approx(math.sqrt(2))
    assert mi.half_width == pytest.approx(12.706 * math.sqrt(2) / math.sqrt(2), abs=1e-3)  # 6.5x the z band
    assert mean_interval([5.0]).half_width is None and mean_interval([]) is None
    st_ = describe([1.0, 3.0])  # aamsim batch's aggregate uses the same quantile (no SciPy)
    assert st_.ci95_high == pytest.approx(2.0 + 12.706, abs=1e-3)


def _run(name: str, rewards: list[float], episodes: list[list[float]]) -> TrainRun:
    n = len(rewards)
    curve = {"iteration": np.arange(1, n + 1, dtype=float), "reward_mean": np.array(rewards)}
    return TrainRun(Path(name), "algo", curve, episodes, episodes, None, None, 1)


def test_the_band_over_runs_ends_where_the_shortest_run_ends():
    long_run = _run("a", [1.0, 2.0, 3.0, 4.0], [[1.0], [2.0], [3.0], [4.0]])
    short_run = _run("b", [3.0, 4.0], [[3.0], [4.0]])
    it, mean, half, what = band([long_run, short_run], "reward_mean", "episode_rewards")
    assert list(it) == [1, 2]  # not iterations 3 and 4 with a within-run band
    assert list(mean) == [2.0, 3.0]
    assert half == pytest.approx([12.706, 12.706], abs=1e-3)  # s = sqrt(2), n = 2, t(1) = 12.706
    assert what == "over 2 training runs"


def test_one_run_bands_over_its_episodes():
    run = _run("a", [2.0, 5.0], [[1.0, 3.0], [5.0]])
    _, mean, half, what = band([run], "reward_mean", "episode_rewards")
    assert list(mean) == [2.0, 5.0] and half[0] == pytest.approx(12.706, abs=1e-3) and half[1] == 0.0
    assert "1 run" in what


def test_a_learned_ratio_interval_is_over_training_runs_a_baseline_over_episodes():
    # Two training runs, 3 episodes each: mean ratios 0.2 and 0.4; the interval has 1 degree of freedom.
    learned = {("runA", 1): 0.1, ("runA", 2): 0.2, ("runA", 3): 0.3, ("runB", 1): 0.4, ("runB", 2): 0.4,
               ("runB", 3): 0.4}
    half = 12.7062 * math.sqrt(0.02) / math.sqrt(2)
    text = ratio_interval(learned)
    assert "over 2 training runs" in text
    lo, hi = (float(x) for x in text.split(": ")[1].split(" .. "))
    assert lo == pytest.approx(0.3 - half, abs=1e-3) and hi == pytest.approx(0.3 + half, abs=1e-3)
    baseline = {("", 1): 0.5, ("", 2): 0.7, ("", 3): None}
    assert "over 2 episodes" in ratio_interval(baseline)
    assert "n/a (1 training run)" in ratio_interval({("runA", 1): 0.1, ("runA", 2): 0.3})


def test_a_cost_measured_on_some_episodes_says_on_how_many():
    """A cell pooling an evaluation recorded before a metric existed with one that has it: the mean of the
    episodes that have it, marked as theirs (here 2 of 4), never read as the whole cell's."""
    from rlbridge.experiment.report import Cell, cost_cells, parking_note

    c = Cell()
    c.seen.update({"old|0", "old|1", "new|0", "new|1"})
    for v in (100.0, 100.0, 98.0, 100.0):
        c.values["operational.flights_completed"].append(v)
    c.values["operational.holding_flight_share"] += [0.05, 0.15]
    c.values["operational.parked_at_time_limit"] += [2.0, 0.0]
    cells = dict(zip(("flights completed", "airborne holding", "flights holding", "parked", "delay", "advisories"),
                     cost_cells(c)))
    assert cells["flights completed"] == "99.5"
    assert cells["flights holding"] == "10.0 (2 of 4 episodes)"
    assert cells["parked"] == "1.00 (2 of 4 episodes)"
    assert cells["airborne holding"] == "n/a"
    assert parking_note({"x": c}, ["x"]) == " — PARKS AIRCRAFT: 1.00 per episode hovering (2 of 4 episodes) at the time limit on x"
