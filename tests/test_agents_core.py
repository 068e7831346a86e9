"""Closed-form checks of the algorithms' exact pieces (rlbridge.agents.core)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from rlbridge.agents.core import (
    LinearSchedule,
    PackedIntruders,
    attention_pool,
    categorical_terms,
    compute_gae,
    ddqn_target,
    dqn_target,
    episode_seed,
    masked_softmax,
    ppo_clip_loss,
    rolling_mean,
    segment_attention_pool,
    value_loss,
)


# ----------------------------------------------------------------------------------- GAE
def test_gae_single_chain_by_hand():
    # Three steps, terminal at the end; gamma 0.9, lambda 0.5.
    r = np.array([1.0, 0.0, 2.0])
    v = np.array([0.5, 1.0, 1.5])
    nv = np.array([1.0, 1.5, 9.0])  # V(s1), V(s2), V(s3) (ignored: terminal)
    term = np.array([False, False, True])
    adv, ret = compute_gae(r, v, nv, term, term, gamma=0.9, lam=0.5)
    d2 = 2.0 - 1.5
    d1 = 0.0 + 0.9 * 1.5 - 1.0
    d0 = 1.0 + 0.9 * 1.0 - 0.5
    a2 = d2
    a1 = d1 + 0.45 * a2
    a0 = d0 + 0.45 * a1
    np.testing.assert_allclose(adv, [a0, a1, a2])
    np.testing.assert_allclose(ret, adv + v)


def test_gae_lambda_one_is_monte_carlo_and_zero_is_td():
    rng = np.random.default_rng(0)
    n = 6
    r, v = rng.normal(size=n), rng.normal(size=n)
    nv = np.append(v[1:], 0.0)
    term = np.zeros(n, bool)
    term[-1] = True
    _, ret1 = compute_gae(r, v, nv, term, term, gamma=0.95, lam=1.0)
    mc = np.array([sum(0.95 ** (k - t) * r[k] for k in range(t, n)) for t in range(n)])
    np.testing.assert_allclose(ret1, mc, atol=1e-12)
    adv0, _ = compute_gae(r, v, nv, term, term, gamma=0.95, lam=0.0)
    np.testing.assert_allclose(adv0, r + 0.95 * np.where(term, 0, nv) - v)


def test_gae_truncation_bootstraps_but_stops_the_chain():
    r = np.array([1.0, 1.0])
    v = np.array([0.0, 0.0])
    nv = np.array([0.0, 10.0])
    term = np.array([False, False])
    ends = np.array([False, True])  # truncated after the second step
    adv, _ = compute_gae(r, v, nv, term, ends, gamma=0.5, lam=1.0)
    np.testing.assert_allclose(adv, [1.0 + 0.5 * (1.0 + 5.0), 1.0 + 5.0])


def test_gae_interleaved_agents_equal_separate_chains():
    # Agent A at rows 0, 2, 4 and agent B at rows 1, 3: as the rollout worker stores them.
    r = np.array([1.0, -1.0, 2.0, 0.5, 3.0])
    v = np.array([0.1, 0.2, 0.3, 0.4, 0.5])
    nv = np.array([0.3, 0.4, 0.5, 0.7, 0.0])
    term = np.array([False, False, False, False, True])
    ends = np.array([False, False, False, True, True])  # B truncated at row 3, A terminal at row 4
    nxt = np.array([2, 3, 4, -1, -1])
    adv, _ = compute_gae(r, v, nv, term, ends, 0.9, 0.8, next_index=nxt)
    a_adv, _ = compute_gae(r[[0, 2, 4]], v[[0, 2, 4]], nv[[0, 2, 4]], term[[0, 2, 4]], ends[[0, 2, 4]], 0.9, 0.8)
    b_adv, _ = compute_gae(r[[1, 3]], v[[1, 3]], nv[[1, 3]], term[[1, 3]], ends[[1, 3]], 0.9, 0.8)
    np.testing.assert_allclose(adv[[0, 2, 4]], a_adv)
    np.testing.assert_allclose(adv[[1, 3]], b_adv)


def test_gae_rejects_backward_links():
    with pytest.raises(ValueError):
        compute_gae(np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2, bool), np.array([False, True]), 0.9, 0.9,
                    next_index=np.array([0, -1]))


# ------------------------------------------------------------------------------ Q-targets
def test_dqn_and_ddqn_targets_by_hand():
    r = torch.tensor([1.0, 0.0, -1.0])
    q_online = torch.tensor([[1.0, 2.0, 0.0], [3.0, 0.0, 1.0], [0.0, 0.0, 5.0]])
    q_target = torch.tensor([[5.0, 4.0, 0.0], [6.0, 7.0, 1.0], [2.0, 2.0, 2.0]])
    term = torch.tensor([False, True, False])
    # DQN: max of the target network.
    np.testing.assert_allclose(dqn_target(r, q_target, term, 0.9).numpy(), [1 + 0.9 * 5, 0.0, -1 + 0.9 * 2])
    # DDQN: online argmax (1, 0, 2) valued by the target network (4, -, 2).
    np.testing.assert_allclose(ddqn_target(r, q_online, q_target, term, 0.9).numpy(),
                               [1 + 0.9 * 4, 0.0, -1 + 0.9 * 2])


# ------------------------------------------------------------------------------------ PPO
def test_ppo_clipped_loss_by_hand():
    logp_old = torch.zeros(4)
    logp_new = torch.log(torch.tensor([1.5, 1.5, 0.5, 0.5]))
    adv = torch.tensor([1.0, -1.0, 1.0, -1.0])
    loss, info = ppo_clip_loss(logp_new, logp_old, adv, clip=0.2)
    # min(rho A, clip(rho) A): 1.2, -1.5, 0.5, -0.8
    assert loss.item() == pytest.approx(-(1.2 - 1.5 + 0.5 - 0.8) / 4)
    assert info.clip_fraction == 1.0
    assert info.approx_kl > 0


def test_ppo_clipped_samples_have_no_gradient():
    logp_new = torch.log(torch.tensor([1.5, 0.5, 1.05])).requires_grad_()
    adv = torch.tensor([1.0, -1.0, 1.0])
    loss, _ = ppo_clip_loss(logp_new, torch.zeros(3), adv, clip=0.2)
    loss.backward()
    g = logp_new.grad.numpy()
    # Ratio 1.5 with A>0 and 0.5 with A<0 are clipped (no gradient); 1.05 is inside: d/dlogp = -rho A / n.
    np.testing.assert_allclose(g, [0.0, 0.0, -1.05 / 3], rtol=1e-6)


def test_value_loss():
    assert value_loss(torch.tensor([1.0, 3.0]), torch.tensor([0.0, 1.0])).item() == pytest.approx(0.5 * (1 + 4) / 2)


# ------------------------------------------------------------------------------ attention
def test_masked_softmax_ignores_padding_and_handles_all_masked():
    scores = torch.tensor([[1.0, 2.0, 100.0], [0.0, 0.0, 0.0]])
    mask = torch.tensor([[1.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    w = masked_softmax(scores, mask)
    e = math.exp(1.0)
    np.testing.assert_allclose(w[0].numpy(), [1 / (1 + e), e / (1 + e), 0.0], rtol=1e-6)
    assert torch.equal(w[1], torch.zeros(3))
    assert w[0, 2].item() == 0.0  # exactly zero, not just small


def test_attention_pool_padding_values_do_not_matter():
    torch.manual_seed(0)
    values = torch.randn(2, 4, 3)
    scores = torch.randn(2, 4)
    mask = torch.tensor([[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    ctx, w = attention_pool(values, scores, mask)
    values2 = values.clone()
    values2[:, 2:] = 1e6
    scores2 = scores.clone()
    scores2[:, 2:] = 1e3
    ctx2, _ = attention_pool(values2, scores2, mask)
    torch.testing.assert_close(ctx, ctx2)
    assert torch.equal(ctx[1], torch.zeros(3))  # no valid intruder: zero context
    torch.testing.assert_close(w.sum(dim=1), torch.tensor([1.0, 0.0]))


def test_d2mava_network_ignores_padded_intruders():
    from rlbridge.agents.d2mava import ActorCritic, D2MAVAConfig

    torch.manual_seed(1)
    for shared in (False, True):
        net = ActorCritic(9, 11, 3, D2MAVAConfig(shared=shared))
        own = torch.randn(3, 9)
        intr = torch.randn(3, 5, 11)
        mask = torch.tensor([[1, 1, 1, 0, 0], [1, 0, 0, 0, 0], [0, 0, 0, 0, 0]], dtype=torch.float32)
        logits, value = net(own, intr, mask)
        intr2 = intr.clone()
        intr2[mask == 0] = torch.randn(int((mask == 0).sum()), 11) * 100
        logits2, value2 = net(own, intr2, mask)
        torch.testing.assert_close(logits, logits2)
        torch.testing.assert_close(value, value2)


def test_segment_attention_pool_by_hand():
    # Ownship 0: intruders with scores 0 and ln 3 -> weights 1/4, 3/4; ownship 1: none -> zero context.
    values = torch.tensor([[4.0, 0.0], [0.0, 8.0]])
    scores = torch.tensor([0.0, math.log(3.0)])
    ctx, w = segment_attention_pool(values, scores, torch.tensor([0, 0]), 2)
    torch.testing.assert_close(w, torch.tensor([0.25, 0.75]))
    torch.testing.assert_close(ctx, torch.tensor([[1.0, 6.0], [0.0, 0.0]]))


def test_packed_gather_returns_each_rows_valid_intruders_in_order():
    intr = torch.arange(3 * 4, dtype=torch.float32).reshape(3, 4, 1)
    mask = torch.tensor([[1, 1, 0, 0], [0, 0, 0, 0], [1, 1, 1, 0]], dtype=torch.float32)
    packed = PackedIntruders.from_padded(intr, mask)
    rows, seg = packed.gather(torch.tensor([2, 1, 0]))
    assert rows[:, 0].tolist() == [8.0, 9.0, 10.0, 0.0, 1.0]
    assert seg.tolist() == [0, 0, 0, 2, 2]


def test_static_gather_pads_to_the_bucket_with_an_extra_segment():
    intr = torch.arange(3 * 4, dtype=torch.float32).reshape(3, 4, 1)
    mask = torch.tensor([[1, 1, 0, 0], [0, 0, 0, 0], [1, 1, 1, 0]], dtype=torch.float32)
    rows, seg = PackedIntruders.from_padded(intr, mask).gather_static(torch.tensor([2, 1, 0]), bucket=8)
    # gather()'s five rows, then three padding rows (packed row 0) in segment 3 = len(idx).
    assert rows[:, 0].tolist() == [8.0, 9.0, 10.0, 0.0, 1.0, 0.0, 0.0, 0.0]
    assert seg.tolist() == [0, 0, 0, 2, 2, 3, 3, 3]
    rows, seg = PackedIntruders.from_padded(intr, mask).gather_static(torch.tensor([1, 2]), bucket=3)
    assert rows[:, 0].tolist() == [8.0, 9.0, 10.0] and seg.tolist() == [1, 1, 1]  # exactly full: no padding


@pytest.mark.parametrize("shared", [False, True])
def test_static_forward_gives_the_packed_networks_outputs_and_gradients(shared):
    from rlbridge.agents.d2mava import ActorCritic, D2MAVAConfig

    torch.manual_seed(2)
    net = ActorCritic(9, 11, 3, D2MAVAConfig(shared=shared))
    own, intr = torch.randn(6, 9), torch.randn(6, 5, 11)
    mask = (torch.arange(5)[None, :] < torch.tensor([5, 0, 2, 1, 3, 0])[:, None]).float()
    idx = torch.tensor([4, 0, 1, 2, 5])
    packed = PackedIntruders.from_padded(intr, mask)
    out = []
    for static in (False, True):
        net.zero_grad()
        if static:
            rows, seg = packed.gather_static(idx, bucket=16)  # 10 valid rows + 6 padding rows
            logits, value = net.forward_static(own[idx], rows, seg)
        else:
            rows, seg = packed.gather(idx)
            logits, value = net.forward_packed(own[idx], rows, seg)
        (logits.square().sum() + value.sum()).backward()
        out.append((logits.detach(), value.detach(), [p.grad.clone() for p in net.parameters()]))
    # Equal to rounding, not to the last bit: the padded gather multiplies 16 rows where the packed one
    # multiplies 10, and the BLAS picks its kernel and its thread split by shape. On an AMD EPYC with two
    # threads the logits differed by 2.3e-10 (relative 8.5e-7); with one thread, and on the Intel machines
    # before, they were bit-identical. The six padding rows counted into a real row's attention move that
    # row's logits by 8.9e-4 here, far outside the tolerance.
    torch.testing.assert_close(out[1][0], out[0][0], rtol=1e-6, atol=1e-7)
    torch.testing.assert_close(out[1][1], out[0][1], rtol=1e-6, atol=1e-7)
    for g_packed, g_static in zip(out[0][2], out[1][2]):
        torch.testing.assert_close(g_static, g_packed, rtol=1e-6, atol=1e-7)


def test_categorical_terms_are_torch_categoricals():
    torch.manual_seed(0)
    logits = torch.randn(64, 3) * 5
    logits[0] = torch.tensor([-torch.inf, 0.0, 1.0])  # a masked action: clamped in the entropy, as torch does
    actions = torch.randint(0, 3, (64,))
    actions[0] = 2
    dist = torch.distributions.Categorical(logits=logits)
    logp, entropy = categorical_terms(logits, actions)
    assert torch.equal(logp, dist.log_prob(actions)) and torch.equal(entropy, dist.entropy())


@pytest.mark.parametrize("shared", [False, True])
def test_packed_attention_gives_the_padded_networks_outputs_and_gradients(shared):
    from rlbridge.agents.d2mava import ActorCritic, D2MAVAConfig

    torch.manual_seed(2)
    net = ActorCritic(9, 11, 3, D2MAVAConfig(shared=shared))
    own = torch.randn(6, 9)
    intr = torch.randn(6, 5, 11)
    counts = torch.tensor([5, 0, 2, 1, 3, 0])
    mask = (torch.arange(5)[None, :] < counts[:, None]).float()
    idx = torch.tensor([4, 0, 1, 2, 5])
    grads = []
    for packed in (False, True):
        net.zero_grad()
        if packed:
            rows, seg = PackedIntruders.from_padded(intr, mask).gather(idx)
            logits, value = net.forward_packed(own[idx], rows, seg)
        else:
            logits, value = net(own[idx], intr[idx], mask[idx])
        (logits.square().sum() + value.sum()).backward()
        grads.append((logits.detach(), value.detach(), [p.grad.clone() for p in net.parameters()]))
    torch.testing.assert_close(grads[0][0], grads[1][0])
    torch.testing.assert_close(grads[0][1], grads[1][1])
    for g_pad, g_pack in zip(grads[0][2], grads[1][2]):
        torch.testing.assert_close(g_pad, g_pack, rtol=1e-5, atol=1e-6)


# -------------------------------------------------------------------------------- helpers
def test_linear_schedule_and_rolling_mean():
    eps = LinearSchedule(0.999, 0.0001, 500_000)
    assert eps(0) == pytest.approx(0.999)
    assert eps(250_000) == pytest.approx((0.999 + 0.0001) / 2)
    assert eps(10**7) == pytest.approx(0.0001)
    np.testing.assert_allclose(rolling_mean([1, 2, 3, 4], 2), [1.0, 1.5, 2.5, 3.5])
    np.testing.assert_allclose(rolling_mean([1, 2, 3], 25), [1.0, 1.5, 2.0])


def test_episode_seeds_are_deterministic_and_distinct():
    seeds = {episode_seed(0, it, w) for it in range(20) for w in range(4)}
    assert len(seeds) == 80
    assert episode_seed(3, 5, 1) == episode_seed(3, 5, 1)
    assert all(0 <= s < 2**31 for s in seeds)
