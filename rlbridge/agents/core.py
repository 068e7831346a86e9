"""Exact building blocks shared by the algorithms (each has a closed-form unit test).

* :func:`compute_gae` — generalized advantage estimation over many agents' interleaved
  transitions (Schulman et al. 2016);
* :func:`dqn_target`, :func:`ddqn_target` — one-step Q-learning targets (Mnih et al. 2015;
  van Hasselt et al. 2016);
* :func:`ppo_clip_loss`, :func:`value_loss` — PPO's clipped surrogate (Schulman et al. 2017);
  :func:`minibatch_bounds` — the minibatches of one PPO epoch (full-sized only);
* :func:`masked_softmax`, :func:`attention_pool` — attention over a padded set of intruders
  in which padded rows get exactly zero weight;
* :class:`PackedIntruders`, :func:`segment_attention_pool` — the same attention over only the
  valid intruders, packed row after row (the learner's path: on ``nyc_train_100`` an aircraft
  observes 11.2 of its 30 intruder slots on average, so the padded path spends 63 % of its
  intruder work on rows whose weight is exactly zero); :meth:`PackedIntruders.gather_static`
  gathers them into a fixed number of rows (the static path a CUDA graph replays);
* :func:`categorical_terms` — a categorical policy's log-probabilities and entropy, as
  ``torch.distributions.Categorical`` computes them, without its host-reading argument checks;
* :class:`LinearSchedule` — the epsilon schedule;
* :func:`rolling_mean` — the 25-iteration rolling mean that picks the best weights;
* :func:`episode_seed` — deterministic seeds from (seed, iteration, worker).

Conventions: arrays are float64/float32 numpy or torch tensors of shape ``(T,)`` for
per-transition quantities; ``terminated`` means the transition reached a terminal state
(no bootstrap), ``ends`` means the chain of an agent stops after it (terminal, truncated or
the last transition of that agent in the batch).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch


# ----------------------------------------------------------------------------- advantages
def compute_gae(
    rewards: np.ndarray,
    values: np.ndarray,
    next_values: np.ndarray,
    terminated: np.ndarray,
    ends: np.ndarray,
    gamma: float,
    lam: float,
    next_index: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Generalized advantage estimates and value targets.

    ``delta_t = r_t + gamma * (1 - terminated_t) * V(s_{t+1}) - V(s_t)`` and
    ``A_t = delta_t + gamma * lam * (1 - ends_t) * A_{next(t)}``, where ``next(t)`` is the
    agent's following transition: ``t + 1`` when ``next_index`` is None (one agent's
    sequence), else ``next_index[t]`` (must be ``> t`` wherever ``ends_t`` is False).
    A truncated transition has ``terminated=False, ends=True``: it bootstraps from
    ``next_values`` but its advantage does not continue.

    Returns:
        (advantages, returns) with ``returns = advantages + values``, float64 arrays.
    """
    r = np.asarray(rewards, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    nv = np.asarray(next_values, dtype=np.float64)
    term = np.asarray(terminated, dtype=bool)
    end = np.asarray(ends, dtype=bool)
    n = r.shape[0]
    delta = r + gamma * np.where(term, 0.0, nv) - v
    nxt = np.arange(1, n + 1) if next_index is None else np.asarray(next_index, dtype=np.int64)
    if np.any(~end & (nxt <= np.arange(n))):
        raise ValueError("next_index must point forward wherever the chain continues")
    if n and np.any(~end & (nxt >= n)):
        raise ValueError("a chain continues past the end of the batch (mark its last transition in ends)")
    adv = np.zeros(n)
    coef = gamma * lam
    # One backward pass; plain Python floats keep it fast for ~1e5 transitions.
    d_list, e_list, n_list = delta.tolist(), end.tolist(), nxt.tolist()
    out = [0.0] * n
    for t in range(n - 1, -1, -1):
        out[t] = d_list[t] if e_list[t] else d_list[t] + coef * out[n_list[t]]
    adv[:] = out
    return adv, adv + v


# ------------------------------------------------------------------------------ Q-targets
def dqn_target(rewards: torch.Tensor, next_q_target: torch.Tensor, terminated: torch.Tensor,
               gamma: float) -> torch.Tensor:
    """DQN: ``r + gamma * (1 - terminated) * max_a Q_target(s', a)``; next_q_target is (B, A)."""
    return rewards + gamma * (1.0 - terminated.float()) * next_q_target.max(dim=1).values


def ddqn_target(rewards: torch.Tensor, next_q_online: torch.Tensor, next_q_target: torch.Tensor,
                terminated: torch.Tensor, gamma: float) -> torch.Tensor:
    """Double DQN: the online network picks ``a* = argmax_a Q(s', a)``, the target network values it.

    ``r + gamma * (1 - terminated) * Q_target(s', a*)``; both Q arrays are (B, A).
    """
    best = next_q_online.argmax(dim=1, keepdim=True)
    return rewards + gamma * (1.0 - terminated.float()) * next_q_target.gather(1, best).squeeze(1)


# ------------------------------------------------------------------------------------ PPO
@dataclass(frozen=True)
class PPOLossInfo:
    """Diagnostics of one clipped-surrogate evaluation, as 0-d tensors on the loss's device (reading
    them with ``float()`` syncs with the device: the learner reads them once per update, not per step)."""

    clip_fraction: torch.Tensor  # share of samples whose ratio left [1 - clip, 1 + clip]
    approx_kl: torch.Tensor  # E[(ratio - 1) - log ratio], always >= 0


def ppo_clip_loss(logp_new: torch.Tensor, logp_old: torch.Tensor, advantages: torch.Tensor,
                  clip: float) -> tuple[torch.Tensor, PPOLossInfo]:
    """PPO's clipped surrogate, as a loss to minimise.

    ``L = -mean(min(rho * A, clip(rho, 1 - clip, 1 + clip) * A))`` with ``rho = exp(logp_new - logp_old)``.
    """
    log_ratio = logp_new - logp_old
    ratio = torch.exp(log_ratio)
    unclipped = ratio * advantages
    clipped = torch.clamp(ratio, 1.0 - clip, 1.0 + clip) * advantages
    loss = -torch.min(unclipped, clipped).mean()
    with torch.no_grad():
        frac = ((ratio - 1.0).abs() > clip).float().mean()
        kl = ((ratio - 1.0) - log_ratio).mean()
    return loss, PPOLossInfo(frac, kl)


def minibatch_bounds(n: int, batch_size: int) -> list[tuple[int, int]]:
    """(start, end) of the minibatches of one epoch over ``n`` shuffled samples.

    Every minibatch has exactly ``batch_size`` samples; the ``n mod batch_size`` left over are left
    out of this epoch (the next epoch's permutation draws others), so no Adam step is taken on a
    handful of samples whose gradient is mostly noise, and every step has the same shape (what a
    captured CUDA graph needs). With fewer than ``batch_size`` samples, one minibatch of all of them.
    """
    if n <= 0:
        return []
    if n < batch_size:
        return [(0, n)]
    return [(start, start + batch_size) for start in range(0, n - batch_size + 1, batch_size)]


def value_loss(values: torch.Tensor, returns: torch.Tensor) -> torch.Tensor:
    """``0.5 * mean((V - R)^2)``."""
    return 0.5 * ((values - returns) ** 2).mean()


def normalize(x: torch.Tensor, eps: float = 1e-8) -> torch.Tensor:
    """Zero mean, unit standard deviation (a single sample is only centred)."""
    if x.numel() < 2:
        return x - x.mean()
    return (x - x.mean()) / (x.std() + eps)


# ------------------------------------------------------------------------------ attention
def masked_softmax(scores: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Softmax over the last axis restricted to ``mask > 0``; masked entries get exactly 0.

    A row with no valid entry returns all zeros (instead of NaN).
    """
    valid = mask > 0
    neg = torch.finfo(scores.dtype).min
    filled = torch.where(valid, scores, torch.full_like(scores, neg))
    weights = torch.softmax(filled, dim=-1) * valid.to(scores.dtype)
    total = weights.sum(dim=-1, keepdim=True)
    return torch.where(total > 0, weights / total.clamp_min(torch.finfo(scores.dtype).tiny), weights)


def attention_pool(values: torch.Tensor, scores: torch.Tensor, mask: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Weighted sum of ``values`` (B, N, H) with masked-softmax weights of ``scores`` (B, N).

    Returns:
        (context (B, H), weights (B, N)); context is zero when every intruder is masked.
    """
    weights = masked_softmax(scores, mask)
    return torch.einsum("bn,bnh->bh", weights, values), weights


def segment_attention_pool(values: torch.Tensor, scores: torch.Tensor, seg: torch.Tensor, n: int
                           ) -> tuple[torch.Tensor, torch.Tensor]:
    """:func:`attention_pool` over packed rows: ``values`` (K, H) and ``scores`` (K,) of the valid
    intruders, ``seg`` (K,) the ownship row (0..n-1) each belongs to.

    Returns (context (n, H), weights (K,)); an ownship without intruders gets a zero context,
    exactly as a fully masked padded row does.
    """
    # The max shift only keeps exp() finite; it cancels in the ratio, so no gradient flows through it.
    top = torch.full((n,), -torch.inf, dtype=scores.dtype, device=scores.device)
    top = top.scatter_reduce(0, seg, scores.detach(), "amax", include_self=True)
    e = torch.exp(scores - top.index_select(0, seg))
    total = torch.zeros(n, dtype=scores.dtype, device=scores.device).index_add(0, seg, e)
    weights = e / total.index_select(0, seg)
    context = torch.zeros(n, values.shape[1], dtype=values.dtype, device=values.device)
    return context.index_add(0, seg, weights.unsqueeze(1) * values), weights


@dataclass
class PackedIntruders:
    """The valid intruders of many ownship rows, packed: ``rows`` (K, Di) with ``counts[i]`` rows
    of ownship ``i`` starting at ``offsets[i]``. Built once per update; minibatches gather from it."""

    rows: torch.Tensor
    counts: torch.Tensor  # (B,) int64
    offsets: torch.Tensor  # (B,) int64

    @classmethod
    def from_padded(cls, intruders: torch.Tensor, mask: torch.Tensor) -> PackedIntruders:
        valid = mask > 0
        counts = valid.sum(dim=1)
        return cls(intruders[valid], counts, torch.cumsum(counts, 0) - counts)

    def gather(self, idx: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The packed intruders of ownship rows ``idx`` and their segment (position in ``idx``)."""
        c = self.counts.index_select(0, idx)
        seg = torch.repeat_interleave(torch.arange(len(idx), device=idx.device), c)
        first = torch.cumsum(c, 0) - c  # where each ownship's rows start in the minibatch
        pos = self.offsets.index_select(0, idx).index_select(0, seg) + torch.arange(len(seg), device=idx.device) \
            - first.index_select(0, seg)
        return self.rows.index_select(0, pos), seg

    def gather_static(self, idx: torch.Tensor, bucket: int) -> tuple[torch.Tensor, torch.Tensor]:
        """:meth:`gather` into exactly ``bucket`` rows, with shapes that do not depend on the data.

        The first rows are :meth:`gather`'s; the rest are padding, whose segment is ``len(idx)``: an
        extra ownship that :meth:`~rlbridge.agents.d2mava.AttentionEncoder.forward_static` pools apart
        and drops. Padding rows repeat packed row 0, so they stay finite. The caller checks that the
        minibatch's intruders fit (``counts[idx].sum() <= bucket``): more are cut off, silently.
        """
        c = self.counts.index_select(0, idx)
        end = torch.cumsum(c, 0)
        j = torch.arange(bucket, device=idx.device)
        seg = torch.searchsorted(end, j, right=True)  # ownship of row j; len(idx) past the last one
        real = seg < len(idx)
        own = seg.clamp(max=len(idx) - 1)
        pos = self.offsets.index_select(0, idx).index_select(0, own) + j - (end - c).index_select(0, own)
        pos = torch.where(real, pos, torch.zeros_like(pos))
        return self.rows.index_select(0, pos), seg


def categorical_terms(logits: torch.Tensor, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """``log pi(a | s)`` of ``actions`` and the entropy of ``softmax(logits)``, row by row.

    The operations of ``torch.distributions.Categorical(logits=...)``'s ``log_prob`` and ``entropy``
    (so the same floats), without the distribution's argument checks: those read the device, a host
    sync per gradient step that a captured CUDA graph cannot contain.
    """
    norm = logits - logits.logsumexp(dim=-1, keepdim=True)
    logp = norm.gather(-1, actions.long().unsqueeze(-1)).squeeze(-1)
    probs = torch.softmax(norm, dim=-1)
    entropy = -(torch.clamp(norm, min=torch.finfo(norm.dtype).min) * probs).sum(-1)
    return logp, entropy


# ------------------------------------------------------------------------------ schedules
@dataclass(frozen=True)
class LinearSchedule:
    """``start`` at step 0, linearly to ``end`` at ``steps``, constant after."""

    start: float
    end: float
    steps: int

    def __call__(self, t: float) -> float:
        if self.steps <= 0:
            return self.end
        frac = min(max(float(t) / self.steps, 0.0), 1.0)
        return self.start + frac * (self.end - self.start)


def rolling_mean(values: list[float] | np.ndarray, window: int) -> np.ndarray:
    """Trailing mean over the last ``window`` values (fewer at the start)."""
    x = np.asarray(values, dtype=np.float64)
    if x.size == 0:
        return x
    c = np.concatenate([[0.0], np.cumsum(x)])
    idx = np.arange(1, x.size + 1)
    lo = np.maximum(idx - window, 0)
    return (c[idx] - c[lo]) / (idx - lo)


def episode_seed(seed: int, iteration: int, worker: int, episode: int = 0) -> int:
    """A 31-bit episode seed derived deterministically from the run seed and its position."""
    ss = np.random.SeedSequence([int(seed), int(iteration), int(worker), int(episode)])
    return int(ss.generate_state(1, dtype=np.uint32)[0] & 0x7FFFFFFF)
