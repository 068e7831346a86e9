"""Trained policies frozen inside the planner use cases: a corridor policy as the tactical layer, a
planner policy under learning aircraft."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rlbridge.core import EpisodeCore
from rlbridge.experiment.configstore import compose_config
from rlbridge.experiment.train import run_training

DATA = Path(__file__).parent / "data"
CROSS = str(DATA / "strategic_cross.scn")
NO_LAYERS = {"layers_ft": [], "max_delay_slots": 2}
QUICK_DDQN = ["workers=0", "algorithm=ddqn", "train.iterations=1", "train.baseline_episodes=0",
              "train.best_window=1", "algorithm.params.learning_starts=1", "algorithm.params.batch_size=4"]


def train(run: Path, overrides: list[str]) -> Path:
    cfg = compose_config("config", overrides=QUICK_DDQN + overrides)
    run_training(cfg, run)
    return run


def test_trained_corridor_policy_as_tactical_layer_and_trained_planner_as_frozen_planner(tmp_path):
    corridor = train(tmp_path / "corridor", [f"scenario={DATA / 'tiny_conflict.scn'}", "env.time_limit_s=300",
                                             "usecase.params.n_intruders=4"])
    core = EpisodeCore(CROSS, "strategic_planning", {**NO_LAYERS, "tactical": str(corridor)})
    layer = core.usecase.tactical
    assert layer.policy.usecase == "corridor_sa" and layer.corridor.params.n_intruders == 4
    assert layer.corridor.params.obs_format == "flat"  # what the DDQN actor reads
    result = core.reset(1)
    while not result.done:
        result = core.step({"planner": 0})
    m = core.metrics()["strategic_planning"]
    # Every aircraft observed and given the policy's (greedy) action every 10 s while it flew.
    assert m["tactical_decisions"] > 0 and m["flights_planned"] == 4
    planner = train(tmp_path / "planner", ["usecase=strategic_planning", f"scenario={CROSS}",
                                           "usecase.params.layers_ft=[]", "usecase.params.max_delay_slots=2"])
    core = EpisodeCore(CROSS, "hierarchical", {"train": "tactical", "planner": str(planner)})
    assert core.usecase.planning.params.max_delay_slots == 2  # the planner's own training parameters
    assert core.usecase.planning.params.obs_format == "flat"
    result = core.reset(3)
    while not result.done:
        result = core.step({a: 1 for a in result.alive})
    h = core.metrics()["hierarchical"]
    assert h["decided"] == 4 and h["planner"] == str(planner)
    assert np.isfinite(h["mean_delay_s"]) if h["flights_planned"] else h["unplaced"] == 4
