"""Algorithm updates on fixed batches, the replay memory, the rollout worker and the baselines."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from rlbridge.agents import make_learner, usecase_dims
from rlbridge.agents.core import ddqn_target, dqn_target
from rlbridge.agents.ddqn import ReplayMemory, rllib_step_marks
from rlbridge.agents.rollout import EnvSpec, EpisodeBatch, EpisodeStats, RolloutWorker

TINY = str(Path(__file__).parent / "data" / "tiny_conflict.scn")
PARAMS = {"alt_noise_ft": 100.0, "n_intruders": 4}


def dims() -> dict[str, int]:
    return usecase_dims("corridor_sa", PARAMS)


def stats(env_steps: int = 0) -> EpisodeStats:
    return EpisodeStats(0, "x", "", 2, 0, 0.0, 0.0, 0, 0, 0.0, 0.0, env_steps=env_steps)


def hand_batch(d: dict[str, int], flat: bool) -> EpisodeBatch:
    """Two agents: A decides at rows 0, 2 (terminal after row 2's decision -> final row 4); B at rows 1, 3
    (truncated -> final row 5). Rows are stored in step order as the worker does."""
    rng = np.random.default_rng(0)
    m = 6
    if flat:
        obs = {"flat": rng.normal(size=(m, d["flat_dim"])).astype(np.float32)}
    else:
        obs = {"ownship": rng.normal(size=(m, d["own_dim"])).astype(np.float32),
               "intruders": rng.normal(size=(m, d["n_intruders"], d["intruder_dim"])).astype(np.float32),
               "mask": np.ones((m, d["n_intruders"]), np.float32)}
    return EpisodeBatch(
        obs=obs, values=np.array([0.5, 0.1, 0.4, 0.2, 7.0, 0.3], np.float32),
        obs_idx=np.array([0, 1, 2, 3]), next_idx=np.array([2, 3, 4, 5]), actions=np.array([0, 1, 2, 1]),
        logp=np.log(np.full(4, 1 / 3, np.float32)), rewards=np.array([1.0, -1.0, 0.5, 2.0], np.float32),
        terminated=np.array([False, False, True, False]), truncated=np.array([False, False, False, True]),
        agent=np.array([0, 1, 0, 1], np.int32), agents=["A", "B"], stats=stats())


# ----------------------------------------------------------------------------- D2MAV-A
def test_d2mava_advantages_on_a_fixed_batch_by_hand():
    learner = make_learner("d2mava", {"gamma": 0.9, "lam": 0.5}, dims())
    b = hand_batch(dims(), flat=False)
    next_t, ends = b.chains()
    np.testing.assert_array_equal(next_t, [2, 3, -1, -1])
    np.testing.assert_array_equal(ends, [False, False, True, True])
    data = learner.prepare([b])
    # A: rows 0 -> 2 -> terminal.  B: rows 1 -> 3 -> truncated, bootstrap V(row 5) = 0.3.
    a2 = 0.5 - 0.4
    a0 = (1.0 + 0.9 * 0.4 - 0.5) + 0.45 * a2
    b3 = 2.0 + 0.9 * 0.3 - 0.2
    b1 = (-1.0 + 0.9 * 0.2 - 0.1) + 0.45 * b3
    np.testing.assert_allclose(data["adv"], [a0, b1, a2, b3], rtol=1e-6)
    np.testing.assert_allclose(data["ret"], np.array([a0, b1, a2, b3]) + [0.5, 0.1, 0.4, 0.2], rtol=1e-6)
    np.testing.assert_array_equal(data["ownship"], b.obs["ownship"][:4])


@pytest.mark.parametrize("shared", [False, True])
def test_d2mava_update_moves_the_policy_with_the_advantage(shared):
    d = dims()
    learner = make_learner("d2mava", {"shared": shared, "lr": 1e-2, "epochs": 4, "clip": 0.2, "norm_adv": False},
                           d, seed=3)
    # One agent, two decisions from the same state: action 2 was good (+1), action 0 bad (-1).
    b = hand_batch(d, flat=False)
    for k in b.obs:
        b.obs[k][:] = b.obs[k][0]
    b.actions[:] = [2, 0, 2, 0]
    b.rewards[:] = [1.0, -1.0, 1.0, -1.0]
    b.values[:] = 0.0
    b.terminated[:] = True
    own, intr, mask = (torch.from_numpy(b.obs[k][:1]) for k in ("ownship", "intruders", "mask"))
    with torch.no_grad():
        p0 = torch.softmax(learner.model(own, intr, mask)[0], -1)[0]
    out = learner.update([b])
    with torch.no_grad():
        p1 = torch.softmax(learner.model(own, intr, mask)[0], -1)[0]
    assert p1[2] > p0[2] and p1[0] < p0[0]
    assert out["gradient_steps"] == 4  # 4 transitions < batch 512: one minibatch per epoch
    assert 0.0 <= out["clip_fraction"] <= 1.0


def test_ppo_epochs_take_full_minibatches_only():
    from rlbridge.agents.core import minibatch_bounds

    assert minibatch_bounds(0, 512) == []
    assert minibatch_bounds(4, 512) == [(0, 4)]  # fewer than one minibatch: all of them, once
    assert minibatch_bounds(1024, 512) == [(0, 512), (512, 1024)]
    # 1,027 samples: two steps of 512; the 3 left over sit out this epoch (no Adam step on 3 samples)
    assert minibatch_bounds(1027, 512) == [(0, 512), (512, 1024)]
    d = dims()
    learner = make_learner("d2mava", {"batch_size": 3, "epochs": 2}, d, seed=1)
    out = learner.update([hand_batch(d, flat=False)])  # 4 transitions: one minibatch of 3 per epoch
    assert out["gradient_steps"] == 2


def _actor_step(returns_scale: float, shared: bool) -> float:
    """Size of the actor's first update when the returns (and so the critic's gradient) are scaled."""
    d = dims()
    learner = make_learner("d2mava", {"shared": shared, "lr": 1e-3, "epochs": 1, "max_grad_norm": 0.5}, d, seed=5)
    b = hand_batch(d, flat=False)
    b.rewards[:] = b.rewards * returns_scale
    b.values[:] = b.values * returns_scale
    before = [p.detach().clone() for p in learner.model.pi.parameters()]
    learner.update([b])
    return float(sum((p.detach() - q).norm() ** 2 for p, q in zip(learner.model.pi.parameters(), before)) ** 0.5)


def test_no_shared_layers_clips_the_actor_and_the_critic_apart():
    """Advantages are normalised, so the actor's gradient does not grow with the returns; a joint clip
    let the critic's 1e5-times larger gradient shrink the actor's step to almost nothing."""
    assert _actor_step(1e5, shared=False) == pytest.approx(_actor_step(1.0, shared=False), rel=0.05)
    d = dims()
    model = make_learner("d2mava", {"shared": False}, d).model
    groups = model.clip_groups()
    ids = [{id(p) for p in g} for g in groups]
    assert len(groups) == 2 and not ids[0] & ids[1] and ids[0] | ids[1] == {id(p) for p in model.parameters()}
    assert len(make_learner("d2mava", {"shared": True}, d).model.clip_groups()) == 1


# -------------------------------------------------------------------------------- (D)DQN
def test_replay_memory_links_next_observations_and_grows_lazily():
    d = dims()
    mem = ReplayMemory(capacity=5_000_000, initial=8)
    b = hand_batch(d, flat=True)
    mem.add(b)
    assert mem.allocated == 8  # not 5,000,000 rows
    assert mem.transitions() == 4
    s = mem.sample(64, np.random.default_rng(0))
    for obs, nxt, act, term in zip(s["obs"]["flat"], s["next_obs"]["flat"], s["actions"], s["terminated"]):
        row = int(np.flatnonzero((b.obs["flat"] == obs).all(axis=1))[0])
        t = int(np.flatnonzero(b.obs_idx == row)[0])
        np.testing.assert_array_equal(nxt, b.obs["flat"][b.next_idx[t]])
        assert act == b.actions[t] and term == b.terminated[t]
    for _ in range(3):
        mem.add(b)
    assert mem.allocated == 32 and mem.size == 24


def test_replay_memory_ring_wraps_consistently():
    d = dims()
    mem = ReplayMemory(capacity=10, initial=4)
    b = hand_batch(d, flat=True)
    for k in range(5):  # 30 rows through a 10-row ring
        b.obs["flat"][:] = np.arange(6)[:, None] + 100 * k
        mem.add(b)
    assert mem.size == 10 and mem.allocated == 10
    s = mem.sample(200, np.random.default_rng(1))
    # Every sampled next observation is the row two (A) or two (B) steps later of the same episode copy.
    first = s["obs"]["flat"][:, 0]
    nxt = s["next_obs"]["flat"][:, 0]
    assert np.all(nxt - first == 2)
    assert np.all((first // 100) == (nxt // 100))


@pytest.mark.parametrize("double", [True, False])
def test_dqn_targets_and_a_gradient_step_on_a_fixed_batch(double):
    d = dims()
    learner = make_learner("dqn", {"double": double, "lr": 1e-3, "batch_size": 4, "learning_starts": 0,
                                   "train_freq": 1, "target_update": 1000, "gamma": 0.9}, d, seed=0)
    b = hand_batch(d, flat=True)
    learner.memory.add(b)
    sample = {"obs": {"flat": b.obs["flat"][b.obs_idx]}, "next_obs": {"flat": b.obs["flat"][b.next_idx]},
              "actions": b.actions, "rewards": b.rewards, "terminated": b.terminated}
    with torch.no_grad():
        nxt = torch.from_numpy(b.obs["flat"][b.next_idx])
        q_on, q_tg = learner.q(nxt), learner.q_target(nxt)
    r, term = torch.from_numpy(b.rewards), torch.from_numpy(b.terminated)
    expected = ddqn_target(r, q_on, q_tg, term, 0.9) if double else dqn_target(r, q_tg, term, 0.9)
    # By hand for the terminal transition (row 2): the target is its reward.
    assert expected[2].item() == pytest.approx(0.5)
    np.testing.assert_allclose(learner.targets(sample).numpy(), expected.numpy(), rtol=1e-6)
    before = learner.td_loss(sample).item()
    for _ in range(20):
        loss = learner.td_loss(sample)
        learner.optimizer.zero_grad()
        loss.backward()
        learner.optimizer.step()
    assert learner.td_loss(sample).item() < before


def test_dqn_per_transition_schedule_counts_transitions():
    """The earlier ratio, kept as ``schedule=per_transition``: one step per ``train_freq`` transitions."""
    d = dims()
    learner = make_learner("dqn", {"schedule": "per_transition", "batch_size": 8, "learning_starts": 6,
                                   "train_freq": 2, "target_update": 4, "eps_decay_steps": 100}, d)
    b = hand_batch(d, flat=True)
    out = learner.update([b])  # 4 transitions < learning_starts
    assert out["gradient_steps"] == 0
    out = learner.update([b, b])  # 12 collected: (12 - 6) / 2 = 3 steps
    assert out["gradient_steps"] == 3
    assert learner.last_sync >= 8  # target copied at least once after 4 transitions of training
    assert learner.explore(50)["epsilon"] == pytest.approx(0.999 + 0.5 * (0.0001 - 0.999))
    assert learner.explore(50, env_steps=10**6)["epsilon"] == pytest.approx(0.999 + 0.5 * (0.0001 - 0.999))


def test_rllib_step_marks_by_hand():
    # A step at every multiple of the period once the replay holds learning_starts environment steps
    # (RLlib: 7 rounds of 160 before the first of 1,000 steps trains, at 1,120).
    assert rllib_step_marks(0, 1119, 160, 1000) == []
    assert rllib_step_marks(0, 1120, 160, 1000) == [1120]
    assert rllib_step_marks(1120, 1600, 160, 1000) == [1280, 1440, 1600]
    assert rllib_step_marks(0, 320, 160, 0) == [160, 320]
    assert rllib_step_marks(150, 170, 160, 0) == [160]
    assert rllib_step_marks(161, 319, 160, 0) == []


def test_dqn_rllib_schedule_counts_environment_steps():
    """The default ratio: steps, target copies, learning_starts and epsilon in environment steps."""
    d = dims()
    learner = make_learner("dqn", {"batch_size": 8, "rollout_fragment_length": 2, "rllib_num_workers": 3,
                                   "learning_starts": 10, "target_update": 12, "eps_decay_steps": 100}, d)
    assert learner.config.schedule == "rllib" and learner.config.env_steps_per_gradient_step == 6

    def batch(env_steps: int) -> EpisodeBatch:  # 4 transitions whatever the environment steps
        b = hand_batch(d, flat=True)
        b.stats = stats(env_steps)
        return b

    out = learner.update([batch(4)])  # 4 environment steps < learning_starts
    assert out["gradient_steps"] == 0 and "td_loss" not in out
    out = learner.update([batch(4), batch(4)])  # 12: the round ending at 12 is the first with >= 10 stored
    assert out["gradient_steps"] == 1 and learner.last_sync == 12  # 12 - 0 >= 12: copied
    before = {k: v.clone() for k, v in learner.q_target.state_dict().items()}
    out = learner.update([batch(20)])  # 32: steps at 18, 24, 30; a copy at 24 (24 - 12 >= 12), none at 30
    assert out["gradient_steps"] == 4 and learner.last_sync == 24
    assert np.isfinite(out["td_loss"])
    after = learner.q_target.state_dict()
    assert any(not torch.equal(before[k], after[k]) for k in before)  # the copy at 24 happened
    assert any(not torch.equal(after[k], v) for k, v in learner.q.state_dict().items())  # the step at 30 after it
    assert (learner.transitions, learner.env_steps) == (16, 32)
    # Epsilon follows environment steps, not transitions.
    assert learner.explore(10**6, env_steps=50)["epsilon"] == pytest.approx(0.999 + 0.5 * (0.0001 - 0.999))
    assert out["epsilon"] == pytest.approx(0.999 + 0.32 * (0.0001 - 0.999))


def test_dqn_schedule_is_checked():
    with pytest.raises(ValueError, match="schedule='per_aircraft': one of rllib, per_transition"):
        make_learner("dqn", {"schedule": "per_aircraft"}, dims())
    with pytest.raises(ValueError, match="rllib_num_workers must be >= 1"):
        make_learner("dqn", {"rllib_num_workers": 0}, dims())


def test_worker_counts_environment_steps():
    """An episode's environment steps are the engine's steps, counted here by stepping it by hand."""
    env = EnvSpec(TINY, params=PARAMS, time_limit_s=600.0)
    core = env.make("flat")
    result, n = core.reset(4), 0
    while not result.done:
        result = core.step({})
        n += 1
    w = RolloutWorker(env, {"unequipped": {"kind": "unequipped"}})
    (s,) = w.collect([4], "unequipped", record=False)
    assert s.env_steps == n > 0
    assert s.transitions > s.env_steps  # two aircraft share most steps


# ------------------------------------------------------------------------------ rollouts
def test_worker_trajectories_are_consistent_and_deterministic():
    d = dims()
    learner = make_learner("d2mava", {}, d, seed=0)
    env = EnvSpec(TINY, params=PARAMS, time_limit_s=600.0)
    w = RolloutWorker(env, {"policy": learner.actor_spec("d2mava")})
    b1, b2 = w.collect([5, 5], "policy", learner.weights(), {"greedy": False})
    assert len(b1) == b1.stats.transitions > 0
    np.testing.assert_array_equal(b1.actions, b2.actions)
    np.testing.assert_array_equal(b1.rewards, b2.rewards)
    assert np.all(b1.next_idx > b1.obs_idx)
    next_t, ends = b1.chains()
    # Each agent's chain ends exactly once, on arrival or truncation.
    for k in range(len(b1.agents)):
        rows = np.flatnonzero(b1.agent == k)
        assert ends[rows].sum() == 1 and ends[rows[-1]]
        assert np.all(next_t[rows[:-1]] == rows[1:])
    assert b1.stats.reward_total == pytest.approx(float(b1.rewards.sum()), rel=1e-5)
    assert set(b1.obs) == {"ownship", "intruders", "mask"}


def test_unequipped_collides_and_mvp_resolves_the_tiny_conflict():
    env = EnvSpec(TINY, params=PARAMS, time_limit_s=600.0)
    w = RolloutWorker(env, {"unequipped": {"kind": "unequipped"}, "mvp": {"kind": "mvp_speed"}})
    base = w.collect([0, 1, 2], "unequipped", record=False)
    mvp = w.collect([0, 1, 2], "mvp", record=False)
    assert all(s.nmac_events == 1 for s in base)
    assert all(s.metrics["operational"]["advisories"] == 0 for s in base)
    assert sum(s.nmac_events for s in mvp) == 0
    assert all(s.metrics["operational"]["flights_completed"] == 2 for s in mvp)


def test_truncated_agents_bootstrap_from_the_critic_and_arrived_ones_from_zero():
    """At the time limit the stored value of an agent's last observation is the critic's (not 0)."""
    d = dims()
    learner = make_learner("d2mava", {}, d, seed=0)
    env = EnvSpec(TINY, params=PARAMS, time_limit_s=60.0)  # both aircraft still flying at 60 s
    w = RolloutWorker(env, {"policy": learner.actor_spec("d2mava")})
    (b,) = w.collect([3], "policy", learner.weights(), {"greedy": False})
    assert b.truncated.sum() == 2 and not b.terminated.any()
    final = b.next_idx[b.truncated]
    with torch.no_grad():
        _, critic = learner.model(*(torch.from_numpy(b.obs[k][final]) for k in ("ownship", "intruders", "mask")))
    assert np.all(critic.numpy() != 0.0)
    np.testing.assert_allclose(b.values[final], critic.numpy(), rtol=1e-5, atol=1e-7)
    # GAE: a truncated transition's return is r + gamma * V(last observation).
    gamma = learner.config.gamma
    data = learner.prepare([b])
    t = np.flatnonzero(b.truncated)
    np.testing.assert_allclose(data["ret"][t], b.rewards[t] + gamma * critic.numpy(), rtol=1e-5, atol=1e-6)


def test_arrived_agents_bootstrap_from_zero():
    d = dims()
    learner = make_learner("d2mava", {}, d, seed=0)
    b = hand_batch(d, flat=False)  # transition 2 is terminal, its next row holds a value of 7.0
    data = learner.prepare([b])
    assert data["ret"][2] == pytest.approx(0.5)  # reward only: 7.0 is not bootstrapped
    assert data["ret"][3] == pytest.approx(2.0 + learner.config.gamma * 0.3, rel=1e-6)  # truncated: r + gamma V


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 12), st.integers(1, 8), st.lists(st.integers(2, 12), min_size=1, max_size=40),
       st.integers(0, 2**31 - 1))
def test_replay_ring_next_rows_stay_in_their_episode_across_wraps(capacity, initial, lengths, seed):
    """Episodes of any length through a tiny ring (split across its end, partly overwritten): every
    sampled transition's next observation is the row its episode pointed to."""
    rng = np.random.default_rng(seed)
    mem = ReplayMemory(capacity=capacity, initial=initial)
    for k, m in enumerate(x for x in lengths if x <= capacity):
        obs_idx = np.sort(rng.choice(m - 1, size=int(rng.integers(1, m)), replace=False))
        next_idx = np.array([int(rng.integers(o + 1, m)) for o in obs_idx])
        n = len(obs_idx)
        rows = np.stack([np.full(m, k), np.arange(m)], axis=1).astype(np.float32)  # (episode, row) tags
        mem.add(EpisodeBatch({"flat": rows}, np.zeros(m, np.float32), obs_idx, next_idx, np.zeros(n, np.int64),
                             np.zeros(n, np.float32), next_idx.astype(np.float32), np.zeros(n, bool),
                             np.zeros(n, bool), np.zeros(n, np.int32), ["a"], stats()))
        assert mem.size <= capacity and mem.allocated <= capacity
        s = mem.sample(32, rng)
        o, nx = s["obs"]["flat"], s["next_obs"]["flat"]
        np.testing.assert_array_equal(nx[:, 0], o[:, 0])  # same episode
        np.testing.assert_array_equal(nx[:, 1], s["rewards"])  # the row it pointed to (stored as reward)
