"""The overlapped training loop (``train.mode=overlap``): its policy lag, resume, lockstep episodes.

In overlap mode the workers play iteration k+1 while the learner updates on iteration k, so
iteration k's episodes come from the weights after update k-2 (one update behind the serial
loop). These tests rebuild those episodes by hand from the learner and compare.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from omegaconf import OmegaConf

from rlbridge.agents import make_learner, usecase_dims
from rlbridge.agents.core import episode_seed
from rlbridge.agents.rollout import EnvSpec, RolloutWorker
from rlbridge.experiment.configstore import compose_config
from rlbridge.experiment.train import learner_threads, load_checkpoint, run_training

TINY = str(Path(__file__).parent / "data" / "tiny_conflict.scn")
QUICK = [f"scenario={TINY}", "workers=0", "env.time_limit_s=600", "usecase.params.n_intruders=4",
         "train.baseline_episodes=0", "train.best_window=2", "train.checkpoint_every=1", "seed=0",
         "train.episodes_per_worker=2", "algorithm.params.lr=1e-3", "algorithm.params.batch_size=16"]


def compose_train(overrides: list[str]):
    return compose_config("config", overrides=QUICK + overrides)


def episode_rewards(run: Path) -> list[list[float]]:
    with open(run / "learning_curve.csv", newline="") as fh:
        return [[float(x) for x in r["episode_rewards"].split(";")] for r in csv.DictReader(fh)]


def test_overlap_plays_iteration_k_with_the_weights_of_update_k_minus_2(tmp_path):
    run_training(compose_train(["train.mode=overlap", "train.iterations=3"]), tmp_path / "run")
    got = episode_rewards(tmp_path / "run")
    # By hand: the same learner (seed 0), the same episode seeds, updates one iteration behind.
    cfg = compose_train([])
    env = EnvSpec(TINY, "corridor_sa", dict(OmegaConf.to_container(cfg.usecase.params, resolve=True)), 600.0)
    learner = make_learner("d2mava", dict(OmegaConf.to_container(cfg.algorithm.params, resolve=True)),
                           usecase_dims(env.usecase, env.params), "cpu", 0)
    worker = RolloutWorker(env, {"policy": learner.actor_spec("d2mava")})

    def play(it: int, weights):
        return worker.collect([episode_seed(0, it, 0, e) for e in range(2)], "policy", weights, {"greedy": False})

    w0 = learner.weights()
    it1, it2 = play(1, w0), play(2, w0)  # iterations 1 and 2: the initial weights
    learner.update(it1)
    it3 = play(3, learner.weights())  # iteration 3: after update 1 only
    for k, batches in enumerate((it1, it2, it3)):
        np.testing.assert_allclose(got[k], [b.stats.reward_per_aircraft for b in batches], rtol=1e-5)
    # The serial loop plays iteration 2 after update 1: a different policy, so different episodes here.
    run_training(compose_train(["train.mode=serial", "train.iterations=2"]), tmp_path / "serial")
    serial = episode_rewards(tmp_path / "serial")
    assert serial[0] == got[0]
    np.testing.assert_allclose(serial[1], [b.stats.reward_per_aircraft for b in play(2, learner.weights())],
                               rtol=1e-5)


def test_overlap_resume_continues_as_an_uninterrupted_run(tmp_path):
    run_training(compose_train(["train.mode=overlap", "train.iterations=2"]), tmp_path / "first")
    ckpt = load_checkpoint(tmp_path / "first" / "checkpoints" / "last.pt")
    assert "behaviour_weights" in ckpt  # the weights the next iteration is to be played with
    run_training(compose_train(["train.mode=overlap", "train.iterations=4",
                                f"train.resume={tmp_path / 'first'}"]), tmp_path / "second")
    run_training(compose_train(["train.mode=overlap", "train.iterations=4"]), tmp_path / "straight")
    assert episode_rewards(tmp_path / "second") == episode_rewards(tmp_path / "straight")


@pytest.mark.parametrize("kind", ["d2mava", "dqn"])
def test_lockstep_episodes_are_the_episodes_played_one_after_the_other(kind):
    env = EnvSpec(TINY, params={"n_intruders": 4, "alt_noise_ft": 100.0}, time_limit_s=600.0)
    learner = make_learner(kind, {}, usecase_dims("corridor_sa", {"n_intruders": 4}), seed=3)
    worker = RolloutWorker(env, {"policy": learner.actor_spec(kind)})
    explore = {"greedy": False} if kind == "d2mava" else {"epsilon": 0.5}
    seeds = [11, 12, 13]
    alone = worker.collect(seeds, "policy", learner.weights(), explore)
    together = worker.collect(seeds, "policy", None, explore, lockstep=True)
    assert sum(len(b) for b in alone) > 0
    for a, b in zip(alone, together):
        assert a.stats.seed == b.stats.seed
        for name in ("actions", "rewards", "obs_idx", "next_idx", "terminated", "truncated"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        np.testing.assert_allclose(a.values, b.values, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(a.logp, b.logp, rtol=1e-5, atol=1e-6)


def test_train_mode_and_threads_are_checked(tmp_path):
    with pytest.raises(ValueError, match="train.mode"):
        run_training(compose_train(["train.mode=async", "train.iterations=1"]), tmp_path)
    assert learner_threads("3", 2) == 3
    assert learner_threads("auto", 0) == 1  # in process: the worker's small batches want one thread
    assert learner_threads("auto", 10_000) == 1
    with pytest.raises(ValueError, match="torch_threads"):
        learner_threads(0, 1)
