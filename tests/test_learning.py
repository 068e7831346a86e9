"""CI's honest learning check: DDQN and D2MAV-A learn to resolve the tiny merge conflict.

``tests/data/tiny_conflict.scn``: two aircraft reach the merge fix together and collide
(1 NMAC per episode) when unequipped. Each algorithm trains with the real loop
(:func:`run_training`, real environment, fixed seed, bounded iterations) and its frozen
greedy policy is evaluated on seeds the training never used, against the unequipped
baseline on the same seeds, with the serial loop and with the overlapped one (policy lag of one
update). Hyper-parameters are scaled to the 2-aircraft problem (a few
thousand transitions instead of millions): larger learning rates, small minibatches, a
short epsilon decay, eight episodes per iteration, four observed intruders.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from rlbridge.experiment.configstore import compose_config
from rlbridge.experiment.evaluate import run_evaluation
from rlbridge.experiment.train import run_training

TINY = str(Path(__file__).parent / "data" / "tiny_conflict.scn")
COMMON = [f"scenario={TINY}", "workers=0", "env.time_limit_s=600", "usecase.params.n_intruders=4", "seed=0",
          "train.iterations=30", "train.episodes_per_worker=8", "train.baseline_episodes=0", "train.best_window=5"]
TINY_HYPERPARAMETERS = {
    "d2mava_a": ["algorithm.params.lr=1e-3", "algorithm.params.batch_size=64", "algorithm.params.ent_coef=0.01",
                 "algorithm.params.clip=0.2"],
    # The default (RLlib's) schedule, counted in environment steps (about 2 aircraft each here): one
    # gradient step per environment step instead of the paper's 160.
    "ddqn": ["algorithm.params.lr=1e-3", "algorithm.params.batch_size=64", "algorithm.params.eps_decay_steps=1500",
             "algorithm.params.learning_starts=100", "algorithm.params.target_update=250",
             "algorithm.params.rollout_fragment_length=1", "algorithm.params.rllib_num_workers=1",
             "algorithm.params.replay_size=50000"],
}


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["serial", "overlap"])
@pytest.mark.parametrize("algorithm", ["d2mava_a", "ddqn"])
def test_trained_policy_has_fewer_nmacs_than_unequipped(tmp_path, algorithm, mode):
    # overlap: every iteration is played with the weights one update behind (docs/algorithms.md).
    cfg = compose_config("config", overrides=[f"algorithm={algorithm}", f"train.mode={mode}", *COMMON,
                                              *TINY_HYPERPARAMETERS[algorithm]])
    ecfg = compose_config("evaluate", overrides=[f"run={tmp_path / 'train'}", "workers=0", "episodes=5", "seed=1000",
                                                 "env.time_limit_s=600", "baselines=[]"])
    run_training(cfg, tmp_path / "train")
    ev = run_evaluation(ecfg, tmp_path / "eval")
    learned, base = ev["policies"][algorithm], ev["policies"]["unequipped"]
    assert base["nmac_events"]["mean"] == 1.0  # the conflict is there on every evaluation seed
    assert learned["nmac_events"]["mean"] < base["nmac_events"]["mean"]
    # Not by everyone hovering out of the way: flights arrive (with seed 0 both do; other seeds sometimes
    # keep one aircraft waiting), and the use case's reward is better than unequipped.
    assert learned["operational"]["flights_completed"]["mean"] >= 1.0
    assert learned["reward_per_aircraft"]["mean"] > base["reward_per_aircraft"]["mean"]
