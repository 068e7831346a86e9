"""A training run's learning curve has its use case's columns (UseCaseSpec.curve); the corridor's stays
the header every earlier run wrote, and a curve that exists keeps its own header when a run resumes."""

from __future__ import annotations

import csv
import math
from dataclasses import replace
from pathlib import Path

import pytest

from rlbridge.experiment.configstore import compose_config
from rlbridge.experiment.train import CURVE_COLUMNS, CurveWriter, curve_columns, discard_after, run_training
from rlbridge.usecases import usecase_spec
from rlbridge.usecases.spec import CurveColumn

DATA = Path(__file__).parent / "data"
# The header of every corridor_sa run's learning_curve.csv before use cases declared their columns.
CORRIDOR_HEADER = ("iteration,wall_s,sim_s,episodes,reward_mean,reward_std,episode_rewards,nmac_per_aircraft,"
                   "lowc_per_aircraft,episode_nmac_per_aircraft,aircraft_states,aircraft_states_total,states_per_s,"
                   "rollout_s,update_s,policy_loss,value_loss,entropy,approx_kl,clip_fraction,explained_variance,"
                   "td_loss,epsilon,gradient_steps")
REACH_OWN = "arrivals_per_aircraft,episode_arrivals_per_aircraft,nmac_per_aircraft,lowc_per_aircraft"


def test_the_corridor_header_is_unchanged():
    assert ",".join(curve_columns(usecase_spec("corridor_sa").curve)) == CORRIDOR_HEADER
    assert ",".join(CURVE_COLUMNS) == CORRIDOR_HEADER


def test_a_column_reads_its_metric_per_aircraft_or_as_is():
    metrics = {"safety": {"nmac_events": 3}, "reach_destination": {"arrivals": 4, "mean_m": None}}
    assert CurveColumn("a", "safety.nmac_events").value(metrics, 6) == 0.5
    assert CurveColumn("a", "reach_destination.arrivals", per_aircraft=False).value(metrics, 6) == 4.0
    assert CurveColumn("a", "safety.nmac_events").value(metrics, 0) == 3.0  # no aircraft: not a division by 0
    assert math.isnan(CurveColumn("a", "reach_destination.mean_m").value(metrics, 6))
    assert math.isnan(CurveColumn("a", "strategic_planning.unplaced").value(metrics, 6))


def test_repeated_column_names_are_refused():
    with pytest.raises(ValueError, match="column names repeat"):
        replace(usecase_spec("corridor_sa"),
                curve=(CurveColumn("x", "safety.nmac_events"), CurveColumn("x", "safety.lowc_events")))


def test_reach_destination_training_writes_its_own_columns(tmp_path):
    cfg = compose_config("config", ["usecase=reach_destination", "algorithm=ddqn_per_transition",
                                    f"scenario={DATA / 'tiny_conflict.scn'}", "workers=0", "train.iterations=2",
                                    "env.time_limit_s=300", "train.baseline_episodes=1"])
    run_training(cfg, tmp_path)
    lines = (tmp_path / "learning_curve.csv").read_text().splitlines()
    assert lines[0] == CORRIDOR_HEADER.replace("nmac_per_aircraft,lowc_per_aircraft,episode_nmac_per_aircraft",
                                               REACH_OWN)
    rows = list(csv.DictReader(lines))
    assert [r["iteration"] for r in rows] == ["1", "2"]
    for r in rows:
        arrivals = float(r["arrivals_per_aircraft"])
        assert 0.0 <= arrivals <= 1.0  # each aircraft arrives at most once
        each = [float(x) for x in r["episode_arrivals_per_aircraft"].split(";")]
        assert len(each) == int(r["episodes"]) and sum(each) / len(each) == pytest.approx(arrivals, rel=1e-5)
    baseline = (tmp_path / "baseline.json").read_text()
    assert '"arrivals_per_aircraft"' in baseline and "episode_arrivals" not in baseline


def test_an_existing_curve_keeps_its_header(tmp_path):
    # A run written before its use case declared its columns resumes under its old header.
    curve = tmp_path / "learning_curve.csv"
    curve.write_text(CORRIDOR_HEADER + "\n" + "1," + ",".join(["0"] * (len(CURVE_COLUMNS) - 1)) + "\n"
                     + "2," + ",".join(["0"] * (len(CURVE_COLUMNS) - 1)) + "\n")
    discard_after(tmp_path, 1)
    writer = CurveWriter(curve, curve_columns(usecase_spec("reach_destination").curve))
    writer.write({"iteration": 2, "nmac_per_aircraft": "0.5", "arrivals_per_aircraft": "1"})
    lines = curve.read_text().splitlines()
    assert lines[0] == CORRIDOR_HEADER and len(lines) == 3
    assert next(r for r in csv.DictReader(lines) if r["iteration"] == "2")["nmac_per_aircraft"] == "0.5"
