"""D2MAV-A's static path: PPO gradient steps of fixed shapes, captured once on a GPU.

The eager update (:meth:`rlbridge.agents.d2mava.D2MAVALearner.update`) gathers each minibatch's
packed intruders with a data-dependent number of rows, which a CUDA graph cannot replay. Here
every full minibatch (``batch_size`` transitions) gathers exactly ``bucket`` packed rows: its
valid intruders, then padding rows assigned to an extra segment that the attention pools apart
and the network drops (:meth:`~rlbridge.agents.core.PackedIntruders.gather_static`), so the
step's loss and gradients are those of the eager step (the padding contributes exact zeros).
All inputs sit in device buffers allocated once and refilled each update (one pinned copy per
array), the epochs' permutations are drawn from the learner's generator exactly as the eager
path draws them, and the losses are summed on the device and read once per update.

A minibatch that does not fit (more valid intruders than ``bucket``, or the single short
minibatch of an update smaller than ``batch_size``) takes the eager step instead, with a logged
note: slower, never wrong. ``bucket`` is fixed at the first update: 1.25 times its largest
minibatch, rounded up to 256 rows (on ``nyc_train_100`` a minibatch of 512 holds about 5,700
valid intruders, with a spread of a few hundred).
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
import torch
from torch import nn

from rlbridge.agents.capture import CapturedStep, copy_into, host_to_device
from rlbridge.agents.core import (
    PackedIntruders,
    categorical_terms,
    minibatch_bounds,
    normalize,
    ppo_clip_loss,
    value_loss,
)

log = logging.getLogger("rlbridge.d2mava")

BUCKET_QUANTUM = 256  # rows
BUCKET_HEADROOM = 1.25


def bucket_for(largest: int) -> int:
    """The packed rows of a minibatch's bucket: ``largest`` with 25 % headroom, in multiples of 256."""
    need = int(np.ceil(max(int(largest), 1) * BUCKET_HEADROOM))
    return -(-need // BUCKET_QUANTUM) * BUCKET_QUANTUM


def _room(n: int) -> int:
    """Buffer rows for ``n``: 25 % headroom, so that updates of similar size reuse the buffers (and the graph)."""
    return max(1024, -(-int(n * 1.25) // 1024) * 1024)


class StaticPPO:
    """The static update of one :class:`~rlbridge.agents.d2mava.D2MAVALearner` (see the module docstring).

    Args:
        learner: the learner whose model, optimiser, generator and counters it updates.
        capture: record the gradient step in a CUDA graph (CUDA only); False: run it eagerly.
    """

    def __init__(self, learner: Any, capture: bool):
        self.learner = learner
        self.capture = capture
        self.bucket: int | None = None  # packed intruder rows per minibatch, fixed at the first update
        self.buf: dict[str, torch.Tensor] = {}
        self.step: CapturedStep | None = None
        self.totals = torch.zeros(5, dtype=torch.float64, device=learner.device)

    # ------------------------------------------------------------------ buffers
    def _load(self, data: dict[str, np.ndarray], counts: np.ndarray, rows: np.ndarray) -> None:
        """Copy the update's arrays into the static buffers (reallocated, and the graph dropped, when too small)."""
        dev = self.learner.device
        n, k = len(counts), len(rows)
        if not self.buf or n > self.buf["own"].shape[0] or max(k, 1) > self.buf["rows"].shape[0]:
            n_cap, k_cap = _room(n), _room(max(k, 1))
            self.buf = {"own": torch.zeros((n_cap, data["ownship"].shape[1]), device=dev),
                        "rows": torch.zeros((k_cap, data["intruders"].shape[2]), device=dev),
                        "counts": torch.zeros(n_cap, dtype=torch.int64, device=dev),
                        "offsets": torch.zeros(n_cap, dtype=torch.int64, device=dev),
                        "actions": torch.zeros(n_cap, dtype=torch.int64, device=dev),
                        "logp": torch.zeros(n_cap, device=dev), "adv": torch.zeros(n_cap, device=dev),
                        "ret": torch.zeros(n_cap, device=dev),
                        "idx": torch.zeros(self.learner.config.batch_size, dtype=torch.int64, device=dev)}
            self.step = None
        copy_into(self.buf["own"], data["ownship"])
        copy_into(self.buf["rows"], rows)
        copy_into(self.buf["counts"], counts)
        copy_into(self.buf["offsets"], np.cumsum(counts) - counts)
        for k_ in ("actions", "logp", "adv", "ret"):
            copy_into(self.buf[k_], data[k_])

    def _build_step(self) -> CapturedStep:
        learner, c, buf, bucket = self.learner, self.learner.config, self.buf, self.bucket
        assert bucket is not None
        packed = PackedIntruders(buf["rows"], buf["counts"], buf["offsets"])

        def step() -> None:
            idx = buf["idx"]
            rows, seg = packed.gather_static(idx, bucket)
            logits, values = learner.model.forward_static(buf["own"].index_select(0, idx), rows, seg)
            logp, entropy = categorical_terms(logits, buf["actions"].index_select(0, idx))
            adv = buf["adv"].index_select(0, idx)
            adv = normalize(adv) if c.norm_adv else adv
            pl, info = ppo_clip_loss(logp, buf["logp"].index_select(0, idx), adv, c.clip)
            vl = value_loss(values, buf["ret"].index_select(0, idx))
            ent = entropy.mean()
            loss = pl + c.vf_coef * vl - c.ent_coef * ent
            loss.backward()
            for group in learner.clip_groups:
                nn.utils.clip_grad_norm_(group, c.max_grad_norm)
            learner.optimizer.step()
            self.totals += torch.stack([pl.detach(), vl.detach(), ent.detach(), info.approx_kl,
                                        info.clip_fraction]).to(self.totals.dtype)

        return CapturedStep(step, list(learner.model.parameters()), learner.optimizer, self.capture)

    # ------------------------------------------------------------------- update
    def update(self, data: dict[str, np.ndarray]) -> tuple[torch.Tensor, int]:
        """``epochs`` passes of minibatch PPO over ``data`` (the learner's ``prepare`` output).

        Returns the summed (policy loss, value loss, entropy, approx. KL, clip fraction) as a device
        tensor and the number of gradient steps.
        """
        learner, c = self.learner, self.learner.config
        n = len(data["actions"])
        valid = data["mask"] > 0
        counts = valid.sum(axis=1).astype(np.int64)
        rows = np.ascontiguousarray(data["intruders"][valid])
        # The eager path's draws, in its order: the same minibatches, step for step.
        perms = np.stack([torch.randperm(n, generator=learner.gen).numpy() for _ in range(c.epochs)])
        bounds = minibatch_bounds(n, c.batch_size)
        sizes = [[int(counts[p[s:e]].sum()) for s, e in bounds] for p in perms]
        full = [k for per_epoch in sizes for (s, e), k in zip(bounds, per_epoch) if e - s == c.batch_size]
        if self.bucket is None and full:
            self.bucket = bucket_for(max(full))
        self._load(data, counts, rows)
        perm_dev = host_to_device(perms, learner.device)
        fits = [[e - s == c.batch_size and self.bucket is not None and k <= self.bucket
                 for (s, e), k in zip(bounds, per_epoch)] for per_epoch in sizes]
        if any(map(any, fits)):
            if self.step is None:
                self.step = self._build_step()
            ep, j = next((ep, j) for ep, row in enumerate(fits) for j, ok in enumerate(row) if ok)
            self.buf["idx"].copy_(perm_dev[ep, bounds[j][0]:bounds[j][1]])
            self.step.prepare()  # the first update records the graph (on CUDA), from these inputs
        self.totals.zero_()
        t = {"ownship": self.buf["own"], "actions": self.buf["actions"], "logp": self.buf["logp"],
             "adv": self.buf["adv"], "ret": self.buf["ret"]}
        packed = PackedIntruders(self.buf["rows"], self.buf["counts"], self.buf["offsets"])
        eager: list[tuple[int, int]] = []
        steps = 0
        for ep in range(c.epochs):
            for (start, end), ok, k in zip(bounds, fits[ep], sizes[ep]):
                if ok:
                    assert self.step is not None
                    self.buf["idx"].copy_(perm_dev[ep, start:end])
                    self.step()
                else:
                    learner.minibatch_step(t, packed, perm_dev[ep, start:end], self.totals)
                    eager.append((end - start, k))
                learner.updates += 1
                steps += 1
        if eager:
            log.info("%d of %d minibatches did not fit the static step (bucket %s packed intruders for %d "
                     "transitions; e.g. %d transitions with %d intruders): eager steps", len(eager), steps,
                     self.bucket, c.batch_size, *eager[0])
        return self.totals, steps
