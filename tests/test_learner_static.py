"""The learners' static path (what a GPU runs captured in CUDA graphs), checked on the CPU.

The static path computes each gradient step in tensors of fixed shapes (packed intruders padded
to a bucket, DDQN's replay on the device); on CUDA the step is captured once and replayed, on a
CPU it runs eagerly. These tests run it eagerly and compare it with the eager path, step for
step on the same batches, and check its fallbacks and its replay memory.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from rlbridge.agents.ddqn import ReplayMemory
from rlbridge.agents.device_replay import DeviceReplay
from rlbridge.agents.rollout import EpisodeBatch, EpisodeStats


def episode(transitions_per_step: list[int], dim: int = 3, offset: float = 0.0) -> EpisodeBatch:
    """An episode whose steps have ``transitions_per_step[k]`` decisions (rows in step order): the k-th
    step's decisions act on its rows and continue on the next step's rows, as the worker records them.
    Row r's observation is ``offset + r`` in every column; the last step's rows are final rows."""
    counts = list(transitions_per_step) + [max(transitions_per_step[-1], 1) if transitions_per_step else 1]
    starts = np.cumsum([0, *counts])
    m = int(starts[-1])
    obs_idx, next_idx = [], []
    for k, n in enumerate(transitions_per_step):
        n = min(n, counts[k + 1])
        obs_idx += list(range(starts[k], starts[k] + n))
        next_idx += list(range(starts[k + 1], starts[k + 1] + n))
    t = len(obs_idx)
    flat = (offset + np.arange(m, dtype=np.float32))[:, None].repeat(dim, 1)
    return EpisodeBatch(obs={"flat": flat}, values=np.zeros(m, np.float32), obs_idx=np.array(obs_idx, np.int64),
                        next_idx=np.array(next_idx, np.int64), actions=np.arange(t, dtype=np.int64) % 3,
                        logp=np.zeros(t, np.float32), rewards=np.arange(t, dtype=np.float32),
                        terminated=np.zeros(t, bool), truncated=np.zeros(t, bool), agent=np.zeros(t, np.int32),
                        agents=["A"], stats=EpisodeStats(0, "x", "", 1, t, 0.0, 0.0, 0, 0, 0.0, 0.0,
                                                         env_steps=len(transitions_per_step)))


# ------------------------------------------------------------------------------ replay on the device
def test_device_replay_valid_range_by_hand():
    # Five episodes of 6 rows (decisions on rows 0-3, final rows 4-5) through a 10-row ring.
    mem = DeviceReplay(10, torch.device("cpu"), initial=4)
    for k in range(5):
        mem.add(episode([2, 2], offset=100 * k))
    assert (mem.rows_written, mem.size, mem.allocated) == (30, 10, 10)
    # Held rows: absolute 20-29. Episode 3 (rows 18-23) keeps its decisions on rows 20 and 21 (its
    # transitions 14 and 15 of 0-19), episode 4 all four: transitions 14..19.
    assert mem.valid_range() == (14, 20)
    s = mem.sample(400)
    first, nxt = s["obs"]["flat"][:, 0].numpy(), s["next_obs"]["flat"][:, 0].numpy()
    assert set(np.unique(first)) == {302.0, 303.0, 400.0, 401.0, 402.0, 403.0}
    np.testing.assert_array_equal(nxt - first, 2.0)  # the agent's next row, same episode


@settings(max_examples=40, deadline=None)
@given(capacity=st.integers(4, 40), episodes=st.lists(st.lists(st.integers(0, 4), min_size=1, max_size=5),
                                                       min_size=1, max_size=8))
def test_device_replay_holds_the_transitions_the_numpy_memory_holds(capacity, episodes):
    dev, ref = DeviceReplay(capacity, torch.device("cpu"), initial=4), ReplayMemory(capacity, initial=4)
    for k, steps in enumerate(episodes):
        b = episode(steps, offset=1000 * k)
        if len(b.values) > capacity:
            with pytest.raises(ValueError, match="does not fit"):
                dev.add(b)
            continue
        dev.add(b)
        ref.add(b)
        assert dev.transitions() == ref.transitions()
    if ref.transitions() == 0:
        return
    # The same set of (observation, next observation, action, reward) among the valid transitions.
    lo, hi = dev.valid_range()
    slots = torch.arange(lo, hi) % dev.allocated
    got = {"obs": {"flat": torch.empty(hi - lo, 3)}, "next_obs": {"flat": torch.empty(hi - lo, 3)},
           "actions": torch.empty(hi - lo, dtype=torch.int64), "rewards": torch.empty(hi - lo),
           "terminated": torch.empty(hi - lo, dtype=torch.bool)}
    dev.gather(slots, got)
    mine = sorted(zip(got["obs"]["flat"][:, 0].tolist(), got["next_obs"]["flat"][:, 0].tolist(),
                      got["actions"].tolist(), got["rewards"].tolist()))
    rows = np.flatnonzero(ref.next_off[: ref.size] > 0)
    nxt = (rows + ref.next_off[rows]) % ref.allocated
    theirs = sorted(zip(ref.obs["flat"][rows, 0].tolist(), ref.obs["flat"][nxt, 0].tolist(),
                        ref.actions[rows].tolist(), ref.rewards[rows].tolist()))
    assert mine == theirs


def test_device_replay_draws_uniformly_over_valid_transitions():
    mem = DeviceReplay(100, torch.device("cpu"), seed=3)
    mem.add(episode([3, 3, 3, 3]))  # 12 transitions
    first = mem.sample(24_000)["obs"]["flat"][:, 0].numpy()
    counts = np.bincount(first.astype(int), minlength=12)[:12]
    assert counts.sum() == 24_000 and np.all(np.abs(counts - 2000) < 200)  # 2000 expected, sd 42


# ------------------------------------------------------------------------------ D2MAV-A
def dims() -> dict[str, int]:
    from rlbridge.agents import usecase_dims

    return usecase_dims("corridor_sa", {"n_intruders": 6})


def ppo_batch(d: dict[str, int], steps: int, seed: int) -> EpisodeBatch:
    """A D2MAV-A episode of random observations: ``steps`` steps of 10 aircraft, 0 to 6 valid intruders
    each (some none), every aircraft continuing to the next step; the last step's rows are final."""
    rng = np.random.default_rng(seed)
    per, m = 10, 10 * (steps + 1)
    mask = (rng.random((m, d["n_intruders"])) < rng.random((m, 1))).astype(np.float32)
    obs = {"ownship": rng.normal(size=(m, d["own_dim"])).astype(np.float32),
           "intruders": rng.normal(size=(m, d["n_intruders"], d["intruder_dim"])).astype(np.float32), "mask": mask}
    t = per * steps
    obs_idx = np.arange(t)
    return EpisodeBatch(obs=obs, values=rng.normal(size=m).astype(np.float32), obs_idx=obs_idx,
                        next_idx=obs_idx + per, actions=rng.integers(0, d["n_actions"], t),
                        logp=np.log(rng.uniform(0.2, 0.5, t)).astype(np.float32),
                        rewards=rng.normal(size=t).astype(np.float32), terminated=np.zeros(t, bool),
                        truncated=np.arange(t) >= t - per, agent=(np.arange(t) % per).astype(np.int32),
                        agents=[f"A{k}" for k in range(per)],
                        stats=EpisodeStats(0, "x", "", per, t, 0.0, 0.0, 0, 0, 0.0, 0.0, env_steps=steps))


def stepwise(learner) -> list[list[torch.Tensor]]:
    """The parameters after every optimiser step of ``learner`` (an optimiser hook: fires on eager runs)."""
    snaps: list[list[torch.Tensor]] = []
    learner.optimizer.register_step_post_hook(
        lambda *_: snaps.append([p.detach().clone() for p in learner.model.parameters()]))
    return snaps


PPO_SMALL = {"batch_size": 32, "epochs": 2, "lr": 1e-3}


@pytest.mark.parametrize("shared", [False, True])
def test_static_ppo_matches_the_eager_update_step_for_step(shared):
    from rlbridge.agents import make_learner

    d = dims()
    batches = [ppo_batch(d, 7, seed=1), ppo_batch(d, 5, seed=2)]  # 120 transitions: 3 full minibatches + 24
    eager = make_learner("d2mava", {**PPO_SMALL, "shared": shared}, d, seed=4, static=False)
    static = make_learner("d2mava", {**PPO_SMALL, "shared": shared}, d, seed=4, static=True)
    assert eager.static is None and static.static is not None
    snaps_e, snaps_s = stepwise(eager), stepwise(static)
    for _ in range(2):
        out_e, out_s = eager.update(batches), static.update(batches)
        for k in ("policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction"):
            assert out_s[k] == pytest.approx(out_e[k], rel=1e-5, abs=1e-7), k
        assert out_s["gradient_steps"] == out_e["gradient_steps"] == eager.updates
    assert len(snaps_e) == len(snaps_s) == 2 * 2 * 3  # two updates of two epochs of three full minibatches
    for step, (pe, ps) in enumerate(zip(snaps_e, snaps_s)):
        for a, b in zip(pe, ps):
            torch.testing.assert_close(b, a, rtol=1e-5, atol=1e-6, msg=f"step {step}")
    # Every minibatch was a full one and took the static step (the short rest is left out of each epoch).
    assert static.static.bucket == 256


def test_static_ppo_minibatches_over_the_bucket_take_the_eager_step(caplog):
    from rlbridge.agents import make_learner

    d = dims()
    batches = [ppo_batch(d, 7, seed=1), ppo_batch(d, 5, seed=2)]
    eager = make_learner("d2mava", PPO_SMALL, d, seed=4, static=False)
    static = make_learner("d2mava", PPO_SMALL, d, seed=4, static=True)
    counts = (np.concatenate([b.obs["mask"][b.obs_idx] for b in batches]) > 0).sum(1)
    static.static.bucket = int(np.sort(counts)[:32].sum())  # about the smallest minibatch: most do not fit
    snaps_e, snaps_s = stepwise(eager), stepwise(static)
    with caplog.at_level("INFO", logger="rlbridge.d2mava"):
        out_e, out_s = eager.update(batches), static.update(batches)
    assert "minibatches did not fit the static step" in caplog.text
    assert out_s["policy_loss"] == pytest.approx(out_e["policy_loss"], rel=1e-5, abs=1e-7)
    for pe, ps in zip(snaps_e, snaps_s):
        for a, b in zip(pe, ps):
            torch.testing.assert_close(b, a, rtol=1e-5, atol=1e-6)
    # A bucket no minibatch fits: every step is the eager one, so the very same floats.
    eager2 = make_learner("d2mava", PPO_SMALL, d, seed=4, static=False)
    static2 = make_learner("d2mava", PPO_SMALL, d, seed=4, static=True)
    static2.static.bucket = 1
    assert eager2.update(batches) == static2.update(batches)
    for a, b in zip(eager2.model.parameters(), static2.model.parameters()):
        assert torch.equal(a, b)


def test_static_ppo_update_smaller_than_a_minibatch_is_eager():
    from rlbridge.agents import make_learner

    d = dims()
    small = [ppo_batch(d, 2, seed=3)]  # 20 transitions < batch_size 32: one short minibatch per epoch
    eager = make_learner("d2mava", PPO_SMALL, d, seed=4, static=False)
    static = make_learner("d2mava", PPO_SMALL, d, seed=4, static=True)
    assert eager.update(small) == static.update(small)
    assert static.static.bucket is None  # no full minibatch: no bucket, no static step
    for a, b in zip(eager.model.parameters(), static.model.parameters()):
        assert torch.equal(a, b)


# ---------------------------------------------------------------------------------- DDQN
def ddqn_sample_into(static, rng: np.random.Generator, d: dict[str, int]) -> dict:
    """A random DDQN minibatch of 16, copied into ``static``'s fixed buffers; returned for the eager step."""
    sample = {"obs": {"flat": rng.normal(size=(16, d["flat_dim"])).astype(np.float32)},
              "next_obs": {"flat": rng.normal(size=(16, d["flat_dim"])).astype(np.float32)},
              "actions": rng.integers(0, d["n_actions"], 16), "rewards": rng.normal(size=16).astype(np.float32),
              "terminated": rng.random(16) < 0.2}
    for k in ("obs", "next_obs"):
        static._batch[k]["flat"].copy_(torch.from_numpy(sample[k]["flat"]))
    for k in ("actions", "rewards", "terminated"):
        static._batch[k].copy_(torch.from_numpy(sample[k]))
    return sample


def test_static_ddqn_step_matches_the_eager_step_for_step():
    from rlbridge.agents import make_learner

    d = dims()
    cfg = {"batch_size": 16, "lr": 1e-3, "learning_starts": 0}
    eager = make_learner("dqn", cfg, d, seed=2, static=False)
    static = make_learner("dqn", cfg, d, seed=2, static=True)
    rng = np.random.default_rng(0)
    for step in range(5):
        loss = eager.gradient_step(ddqn_sample_into(static, rng, d))
        static._loss_sum.zero_()
        static._step()
        assert float(static._loss_sum) == float(loss), step
        for a, b in zip(eager.q.parameters(), static.q.parameters()):
            assert torch.equal(a, b), step


def test_static_ddqn_update_trains_from_the_device_replay():
    from rlbridge.agents import make_learner

    d = dims()
    cfg = {"batch_size": 16, "rollout_fragment_length": 2, "rllib_num_workers": 2, "learning_starts": 8,
           "target_update": 12}
    learner = make_learner("dqn", cfg, d, seed=2, static=True)
    assert isinstance(learner.memory, DeviceReplay)
    flat = episode([10] * 12, dim=d["flat_dim"])
    out = learner.update([flat])  # 12 environment steps: steps at 8 and 12, a copy at 12
    assert out["gradient_steps"] == 2 and learner.last_sync == 12 and np.isfinite(out["td_loss"])
    assert learner.memory.transitions() == 120


# ------------------------------------------------------------------------ capture, devices, workers
def test_capture_warm_up_leaves_weights_and_optimiser_as_they_were():
    """The steps a CUDA capture runs before recording are undone: the graph starts where eager would."""
    from rlbridge.agents.capture import CapturedStep

    torch.manual_seed(0)
    net = torch.nn.Linear(4, 2)
    opt = torch.optim.Adam(net.parameters(), lr=0.1)
    x = torch.randn(8, 4)

    def fn() -> None:
        net(x).square().mean().backward()
        opt.step()

    step = CapturedStep(fn, list(net.parameters()), opt, capture=False)
    before = [p.detach().clone() for p in net.parameters()]
    step.warm_up()  # no optimiser state yet: the state the warm-up created is reset to a fresh one
    assert all(torch.equal(a, b) for a, b in zip(before, net.parameters()))
    assert all(torch.count_nonzero(v) == 0 for s in opt.state.values() for v in s.values())
    step()
    step()  # now with state
    after_two = [p.detach().clone() for p in net.parameters()]
    state = {(id(p), k): v.clone() for p, s in opt.state.items() for k, v in s.items()}
    step.warm_up()
    assert all(torch.equal(a, b) for a, b in zip(after_two, net.parameters()))
    assert all(torch.equal(state[id(p), k], v) for p, s in opt.state.items() for k, v in s.items())
    # And the next step is the one eager Adam takes from there (a fresh reference, same two steps).
    step()
    torch.manual_seed(0)
    ref = torch.nn.Linear(4, 2)
    ref_opt = torch.optim.Adam(ref.parameters(), lr=0.1)
    for _ in range(3):
        ref_opt.zero_grad()
        ref(x).square().mean().backward()
        ref_opt.step()
    assert all(torch.equal(a, b) for a, b in zip(ref.parameters(), net.parameters()))


@pytest.mark.skipif(torch.cuda.is_available(), reason="checks the error of a machine without CUDA")
def test_learners_refuse_cuda_without_cuda():
    from rlbridge.agents import make_learner

    with pytest.raises(ValueError, match="device=cuda: CUDA is not available on this machine"):
        make_learner("d2mava", {}, dims(), "cuda")
    with pytest.raises(ValueError, match="device=cuda:1: CUDA is not available"):
        make_learner("dqn", {}, dims(), "cuda:1")
    with pytest.raises(ValueError, match="device=tpu: not a device"):
        make_learner("dqn", {}, dims(), "tpu")


def test_workers_auto_takes_the_cores_the_learner_leaves():
    from rlbridge.experiment.train import resolve_workers

    assert resolve_workers("auto", "cuda", cores=16) == 15  # one core drives the GPU learner
    assert resolve_workers("auto", "cuda:0", cores=2) == 1
    assert resolve_workers("auto", "cpu", cores=16) == 8  # the learner computes on the other half
    assert resolve_workers("auto", "cpu", cores=1) == resolve_workers("auto", "cuda", cores=1) == 1
    assert resolve_workers(3, "cuda", cores=16) == 3 and resolve_workers("0", "cpu") == 0
    with pytest.raises(ValueError, match="workers must be >= 0 or auto"):
        resolve_workers(-1, "cpu")


def test_optimiser_state_loads_across_adam_implementations():
    """A checkpoint's Adam flags (fused, capturable) do not replace those of the learner that loads it:
    a GPU learner's capturable Adam state trains on a CPU, a CPU one is captured on a GPU."""
    from rlbridge.agents import make_learner

    d = dims()
    batches = [ppo_batch(d, 4, seed=5)]
    a = make_learner("d2mava", PPO_SMALL, d, seed=1, static=False)
    a.update(batches)
    state = copy.deepcopy(a.state_dict())  # as saved: no tensor shared with a
    for g in state["optimizer"]["param_groups"]:  # a capturable Adam's groups, read with map_location="cpu"
        g.update(capturable=True)
    b = make_learner("d2mava", PPO_SMALL, d, seed=2, static=False)
    b.load_state_dict(state)
    assert not any(g["capturable"] for g in b.optimizer.param_groups)
    assert a.update(batches) == b.update(batches)  # a capturable Adam on CPU tensors would raise here
    # The other way: an Adam built fused (as the static path builds it) stays fused, its step counts
    # where the fused kernel keeps them.
    c = make_learner("d2mava", PPO_SMALL, d, seed=3, static=False)
    c.optimizer = torch.optim.Adam(c.model.parameters(), lr=1e-3, eps=1e-5, fused=True)
    c.load_state_dict(copy.deepcopy(a.state_dict()))
    assert all(g["fused"] for g in c.optimizer.param_groups)
    assert all(s["step"].dtype == torch.float32 for s in c.optimizer.state.values())


# ------------------------------------------------------------------------- on a GPU (skipped elsewhere)
needs_cuda = pytest.mark.skipif(not torch.cuda.is_available(), reason="the captured step runs on a GPU only")


@needs_cuda
@pytest.mark.parametrize("shared", [False, True])
def test_captured_ppo_update_on_cuda_matches_the_eager_update_on_cuda(shared):
    """The CUDA graph replays the eager path's arithmetic: same losses, same weights after three updates
    (to float rounding: the captured step runs fused Adam, the eager one the default kernel)."""
    from rlbridge.agents import make_learner

    d = dims()
    batches = [ppo_batch(d, 7, seed=1), ppo_batch(d, 5, seed=2)]
    eager = make_learner("d2mava", {**PPO_SMALL, "shared": shared}, d, "cuda", seed=4, static=False)
    static = make_learner("d2mava", {**PPO_SMALL, "shared": shared}, d, "cuda", seed=4, static=True)
    for _ in range(3):
        out_e, out_s = eager.update(batches), static.update(batches)
        for k in ("policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction"):
            assert out_s[k] == pytest.approx(out_e[k], rel=1e-4, abs=1e-6), k
        assert out_s["gradient_steps"] == out_e["gradient_steps"]
    assert static.static.step is not None and static.static.step.graph is not None  # it was captured
    for a, b in zip(eager.model.parameters(), static.model.parameters()):
        torch.testing.assert_close(b, a, rtol=1e-4, atol=1e-5)


@needs_cuda
def test_captured_ddqn_step_on_cuda_matches_the_eager_step_on_cuda():
    from rlbridge.agents import make_learner

    d = dims()
    cfg = {"batch_size": 16, "lr": 1e-3, "learning_starts": 0}
    eager = make_learner("dqn", cfg, d, "cuda", seed=2, static=False)
    static = make_learner("dqn", cfg, d, "cuda", seed=2, static=True)
    rng = np.random.default_rng(0)
    for step in range(5):
        loss = eager.gradient_step(ddqn_sample_into(static, rng, d))
        static._step.prepare()  # records the graph once; its warm-up steps are undone, their losses not
        static._loss_sum.zero_()  # counted (as the update does)
        static._step()
        assert float(static._loss_sum) == pytest.approx(float(loss), rel=1e-4, abs=1e-6), step
        for a, b in zip(eager.q.parameters(), static.q.parameters()):
            torch.testing.assert_close(b, a, rtol=1e-4, atol=1e-5)
    assert static._step.graph is not None
