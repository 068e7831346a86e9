"""DDQN's replay memory resident on the learner's device, sampled there.

The same memory as :class:`rlbridge.agents.ddqn.ReplayMemory` (observation rows stored once, a
ring of ``capacity`` rows allocated lazily and doubled as it fills, uniform sampling over the
transitions whose observation row is still held), laid out for a GPU: the rows live on the
device, so a minibatch is gathered there without a host copy per gradient step, and the
transitions are kept in their own ring, in the order they were added, so that the ones still
valid form one contiguous range and a uniform draw is one ``randint`` on the device (no
rejection of final-observation rows, no host read).

Why the valid transitions are contiguous: rows are overwritten oldest first, transitions are
added in row order (an episode's transitions point at its own rows, in step order), and a
transition's next row comes after its own; so once the oldest held row is ``r``, exactly the
transitions added since the first one acting on a row ``>= r`` are valid.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from rlbridge.agents.capture import copy_into
from rlbridge.agents.rollout import EpisodeBatch


def ring_rows(allocated: int, needed: int, capacity: int, initial: int) -> int:
    """Rows a lazily grown ring allocates to hold ``needed``: doubling from ``initial``, at most ``capacity``."""
    new = min(capacity, max(initial, allocated))
    while new < needed and new < capacity:
        new = min(capacity, new * 2)
    return new


class DeviceReplay:
    """Ring buffers of observation rows and of transitions on ``device`` (see the module docstring).

    Args:
        capacity: rows held at most (the paper: 5,000,000); transitions are at most as many.
        device: where the rings live and the sampling runs.
        seed: seeds the device generator of the draws.
        initial: rows allocated at first (the ring doubles up to ``capacity`` as it fills).
    """

    def __init__(self, capacity: int, device: torch.device, seed: int = 0, initial: int = 4096):
        if capacity < 1:
            raise ValueError("replay capacity must be positive")
        self.capacity = int(capacity)
        self.device = torch.device(device)
        self._initial = int(initial)
        self.gen = torch.Generator(device=self.device).manual_seed(int(seed))
        self.rows_written = 0  # rows ever added
        self.trans_written = 0  # transitions ever added
        self.obs: dict[str, torch.Tensor] = {}
        self.tr: dict[str, torch.Tensor] = {}  # per transition: obs slot, next slot, action, reward, terminated
        # Host copy of each held transition's absolute row (ascending): where the valid range starts.
        self._tr_row = np.zeros(0, np.int64)
        self.version = 0  # bumped whenever the rings are reallocated (a captured step reading them is stale)

    @property
    def allocated(self) -> int:
        return 0 if not self.obs else next(iter(self.obs.values())).shape[0]

    @property
    def size(self) -> int:
        """Rows held."""
        return min(self.rows_written, self.capacity)

    def _grow(self, rows: int, template: dict[str, np.ndarray]) -> None:
        new = ring_rows(self.allocated, rows, self.capacity, self._initial)
        if new == self.allocated:
            return
        dev, held = self.device, self.rows_written  # before the first wrap rows sit at their absolute index

        def grown(old: torch.Tensor | None, shape: tuple[int, ...], dtype: torch.dtype) -> torch.Tensor:
            out = torch.zeros((new, *shape), dtype=dtype, device=dev)
            if old is not None and held:
                out[:held] = old[:held]
            return out

        self.obs = {k: grown(self.obs.get(k), tuple(v.shape[1:]), torch.from_numpy(v[:0]).dtype)
                    for k, v in template.items()}
        t_held = self.trans_written
        specs = {"slot": torch.int64, "next": torch.int64, "action": torch.int64, "reward": torch.float32,
                 "terminated": torch.bool}
        tr = {}
        for k, dtype in specs.items():
            out = torch.zeros(new, dtype=dtype, device=dev)
            if k in self.tr and t_held:
                out[:t_held] = self.tr[k][:t_held]
            tr[k] = out
        self.tr = tr
        self._tr_row = np.concatenate([self._tr_row, np.zeros(new - len(self._tr_row), np.int64)])
        self.version += 1

    def add(self, batch: EpisodeBatch) -> None:
        """Store an episode's rows and transitions (one host-to-device copy of each array)."""
        m, t = len(batch.values), len(batch)
        if m == 0:
            return
        if m > self.capacity:
            raise ValueError(f"an episode of {m} rows does not fit a replay memory of {self.capacity}")
        if self.allocated < self.capacity:
            self._grow(self.rows_written + m, batch.obs)
        cap = self.allocated
        row0 = self.rows_written
        for k, v in batch.obs.items():
            copy_into(self.obs[k], v, row0 % cap)
        if t:
            t0 = self.trans_written % cap
            copy_into(self.tr["slot"], (row0 + batch.obs_idx) % cap, t0)
            copy_into(self.tr["next"], (row0 + batch.next_idx) % cap, t0)
            copy_into(self.tr["action"], batch.actions.astype(np.int64), t0)
            copy_into(self.tr["reward"], batch.rewards.astype(np.float32), t0)
            copy_into(self.tr["terminated"], batch.terminated.astype(bool), t0)
            idx = (self.trans_written + np.arange(t)) % cap
            self._tr_row[idx] = row0 + batch.obs_idx
        self.rows_written += m
        self.trans_written += t

    def valid_range(self) -> tuple[int, int]:
        """``[lo, hi)``: the absolute numbers of the transitions whose rows are still held."""
        hi = self.trans_written
        lo = hi - min(hi, self.allocated)  # the oldest transition still in its ring
        oldest_row = self.rows_written - self.size
        cap = max(self.allocated, 1)
        top = hi
        while lo < top:  # the first transition acting on a held row (rows ascend with transitions)
            mid = (lo + top) // 2
            if self._tr_row[mid % cap] < oldest_row:
                lo = mid + 1
            else:
                top = mid
        return lo, hi

    def transitions(self) -> int:
        lo, hi = self.valid_range()
        return hi - lo

    def sample_slots(self, n: int) -> torch.Tensor:
        """``n`` transition slots drawn uniformly (with replacement) from the valid ones, on the device."""
        lo, hi = self.valid_range()
        if hi <= lo:
            raise ValueError("the replay memory holds no transition")
        draw = torch.randint(lo, hi, (n,), generator=self.gen, device=self.device)
        return draw % self.allocated

    def gather(self, slots: torch.Tensor, out: dict[str, Any]) -> None:
        """Write the transitions at ``slots`` into ``out``'s tensors (``obs`` and ``next_obs`` dicts,
        ``actions``, ``rewards``, ``terminated``), without allocating: ``out`` may be a captured step's input."""
        rows = self.tr["slot"].index_select(0, slots)
        nxt = self.tr["next"].index_select(0, slots)
        for k, v in self.obs.items():
            torch.index_select(v, 0, rows, out=out["obs"][k])
            torch.index_select(v, 0, nxt, out=out["next_obs"][k])
        torch.index_select(self.tr["action"], 0, slots, out=out["actions"])
        torch.index_select(self.tr["reward"], 0, slots, out=out["rewards"])
        torch.index_select(self.tr["terminated"], 0, slots, out=out["terminated"])

    def sample(self, n: int) -> dict[str, Any]:
        """``n`` transitions uniformly, as new tensors (the layout of ``ReplayMemory.sample``)."""
        out: dict[str, Any] = {
            "obs": {k: torch.empty((n, *v.shape[1:]), dtype=v.dtype, device=self.device) for k, v in self.obs.items()},
            "next_obs": {k: torch.empty((n, *v.shape[1:]), dtype=v.dtype, device=self.device)
                         for k, v in self.obs.items()},
            "actions": torch.empty(n, dtype=torch.int64, device=self.device),
            "rewards": torch.empty(n, dtype=torch.float32, device=self.device),
            "terminated": torch.empty(n, dtype=torch.bool, device=self.device)}
        self.gather(self.sample_slots(n), out)
        return out
