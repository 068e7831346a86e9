"""DQN and Double DQN with a parameter-shared Q-network over every aircraft's transitions.

One Q-network (flat observation -> 128 -> 128 -> one value per action, ReLU) is shared by
all aircraft; every agent's transitions go into one replay memory. Exploration is
epsilon-greedy with a linear schedule; the target network is copied from the online one
every ``target_update`` steps (both counted as the schedule below counts).
``double=True`` uses van Hasselt et al.'s Double-DQN target, ``double=False`` Mnih et al.'s.
The loss is the Huber loss of Mnih et al. (2015). Defaults are the paper's DDQN table.

Scheduling (``schedule``). The paper's hyper-parameters are RLlib keys (Ray 1.x DQN), so the
default ``schedule="rllib"`` counts as RLlib's DQN counted them (docs/algorithms.md cites the
source): *environment steps* (decisions of the multi-agent environment, each advancing every
aircraft by the decision interval; RLlib's ``count_steps_by="env_steps"``). With
``training_intensity=None`` RLlib alternates one round of sampling (``rollout_fragment_length``
environment steps from each of ``num_workers`` workers) with one gradient step of
``batch_size`` (``train_batch_size``), so a gradient step falls at every multiple of
``rollout_fragment_length x rllib_num_workers`` environment steps (4 x 40 = 160 for the paper's
run; our own number of workers does not change the ratio). A step is taken once
``learning_starts`` environment steps were added; the target network is copied after a step
when ``target_update`` environment steps passed since the last copy; epsilon decays over
``eps_decay_steps`` environment steps. ``schedule="per_transition"`` keeps this project's
earlier choice: one gradient step per ``train_freq`` aircraft transitions, and
``learning_starts``, ``target_update`` and the epsilon decay counted in aircraft transitions.

Either way each training iteration first stores the iteration's episodes in the replay
memory, then makes the gradient steps that fall within the iteration's counts; the workers act
with the epsilon reached at the start of the iteration.

On CUDA (``static``) the replay memory lives on the device (:mod:`rlbridge.agents.device_replay`,
sampled there) and the gradient step is captured once in a CUDA graph and replayed
(:mod:`rlbridge.agents.capture`); on a CPU the same step runs eagerly from the numpy memory.

The replay memory is a numpy ring of observation *rows* (see
:mod:`rlbridge.agents.rollout`): an agent's next observation is the row ``next_off`` rows
later, so each observation is stored once. It is allocated lazily and grows by doubling up
to ``replay_size`` rows, so small runs never allocate the paper's 5,000,000 rows.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import nn

from rlbridge.agents.capture import CapturedStep, check_device, load_optimizer_state, static_optimizer
from rlbridge.agents.core import LinearSchedule, ddqn_target, dqn_target
from rlbridge.agents.d2mava import load_numpy_state, to_numpy_state
from rlbridge.agents.device_replay import DeviceReplay, ring_rows
from rlbridge.agents.rollout import ActOutput, EpisodeBatch
from rlbridge.core import StepResult

if TYPE_CHECKING:
    from aamsim.snapshots import TrafficSnapshot

SCHEDULES = ("rllib", "per_transition")


@dataclass
class DDQNConfig:
    """(D)DQN hyper-parameters (paper's Table "DDQN Hyperparameters" as defaults).

    The step counts (``eps_decay_steps``, ``target_update``, ``learning_starts``) are environment
    steps with ``schedule="rllib"`` and aircraft transitions with ``schedule="per_transition"``.
    """

    double: bool = True  # Double DQN target (False: DQN)
    lr: float = 1e-4
    batch_size: int = 512  # RLlib's train_batch_size
    hidden: int = 128  # nodes per layer
    gamma: float = 0.99
    eps_start: float = 0.999
    eps_end: float = 0.0001
    eps_decay_steps: int = 500_000  # RLlib's exploration_config.epsilon_timesteps
    replay_size: int = 5_000_000  # rows
    target_update: int = 50_000  # steps between target-network copies (RLlib's target_network_update_freq)
    # Update ratio (see the module docstring): "rllib" (the paper's run) or "per_transition".
    schedule: str = "rllib"
    rollout_fragment_length: int = 4  # rllib: RLlib DQN's default (not in the paper) [environment steps]
    rllib_num_workers: int = 40  # rllib: the paper's N_workers (the ratio's, not this run's workers)
    learning_starts: int = 1000  # steps before the first gradient step (RLlib's default; not in the paper)
    train_freq: int = 4  # per_transition: transitions per gradient step (not in the paper)
    max_grad_norm: float = 10.0  # gradient clipping (not in the paper)

    def __post_init__(self) -> None:
        if self.schedule not in SCHEDULES:
            raise ValueError(f"algorithm.params.schedule={self.schedule!r}: one of {', '.join(SCHEDULES)}")
        for name in ("rollout_fragment_length", "rllib_num_workers", "train_freq", "batch_size"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"algorithm.params.{name} must be >= 1, not {getattr(self, name)!r}")

    @property
    def env_steps_per_gradient_step(self) -> int:
        """``rollout_fragment_length x rllib_num_workers``: RLlib's natural ratio (schedule="rllib")."""
        return int(self.rollout_fragment_length) * int(self.rllib_num_workers)


def rllib_step_marks(start: int, end: int, period: int, learning_starts: int) -> list[int]:
    """The environment-step counts in ``(start, end]`` at which RLlib's DQN takes a gradient step.

    RLlib samples ``period`` environment steps per round (all workers) and then trains once, so
    steps fall at the multiples of ``period``; a round trains only once the replay holds
    ``learning_starts`` environment steps. Returns the counts ``m * period``, ascending.
    """
    first = max(start // period + 1, -(-int(learning_starts) // period), 1)
    return [m * period for m in range(first, end // period + 1)]


class QNetwork(nn.Module):
    def __init__(self, obs_dim: int, n_actions: int, hidden: int):
        super().__init__()
        self.net = nn.Sequential(nn.Linear(obs_dim, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                                 nn.Linear(hidden, n_actions))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.net(obs)


class ReplayMemory:
    """Ring buffer of observation rows with per-row transition data (see the module docstring)."""

    def __init__(self, capacity: int, initial: int = 4096):
        if capacity < 1:
            raise ValueError("replay capacity must be positive")
        self.capacity = int(capacity)
        self._initial = int(initial)
        self.size = 0  # rows held
        self.pos = 0  # next row to write
        self.obs: dict[str, np.ndarray] = {}
        self.actions = np.zeros(0, np.int64)
        self.rewards = np.zeros(0, np.float32)
        self.terminated = np.zeros(0, bool)
        self.next_off = np.zeros(0, np.int64)  # > 0: a transition starts here; 0: a final observation

    @property
    def allocated(self) -> int:
        return len(self.actions)

    def _grow(self, rows: int, template: dict[str, np.ndarray]) -> None:
        new = ring_rows(self.allocated, rows, self.capacity, self._initial)
        if new == self.allocated:
            return

        def grow(a: np.ndarray, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
            out = np.zeros((new,) + shape, dtype)
            out[: len(a)] = a
            return out

        self.obs = {k: grow(self.obs.get(k, np.zeros((0,) + v.shape[1:], v.dtype)), v.shape[1:], v.dtype)
                    for k, v in template.items()}
        self.actions = grow(self.actions, (), np.int64)
        self.rewards = grow(self.rewards, (), np.float32)
        self.terminated = grow(self.terminated, (), bool)
        self.next_off = grow(self.next_off, (), np.int64)

    def add(self, batch: EpisodeBatch) -> None:
        m = len(batch.values)
        if m == 0:
            return
        if m > self.capacity:
            raise ValueError(f"an episode of {m} rows does not fit a replay memory of {self.capacity}")
        if self.allocated < self.capacity:
            self._grow(self.size + m, batch.obs)  # before the first wrap pos == size
        rows = (self.pos + np.arange(m)) % self.allocated
        for k, v in batch.obs.items():
            self.obs[k][rows] = v
        self.next_off[rows] = 0
        t_rows = rows[batch.obs_idx]
        self.actions[t_rows] = batch.actions
        self.rewards[t_rows] = batch.rewards
        self.terminated[t_rows] = batch.terminated
        self.next_off[t_rows] = batch.next_idx - batch.obs_idx
        self.pos = int(rows[-1] + 1)
        if self.pos == self.capacity:  # wrap only once the ring has its final size
            self.pos = 0
        self.size = min(self.size + m, self.capacity)

    def transitions(self) -> int:
        return int(np.count_nonzero(self.next_off[: self.size]))

    def sample(self, n: int, rng: np.random.Generator) -> dict[str, Any]:
        """``n`` transitions uniformly: obs, next_obs (dicts), actions, rewards, terminated."""
        if self.transitions() == 0:
            raise ValueError("the replay memory holds no transition")
        picked: list[np.ndarray] = []
        got = 0
        while got < n:
            cand = rng.integers(0, self.size, size=int((n - got) * 1.25) + 8)
            cand = cand[self.next_off[cand] > 0]
            picked.append(cand)
            got += len(cand)
        idx = np.concatenate(picked)[:n]
        nxt = (idx + self.next_off[idx]) % max(self.allocated, 1)
        return {"obs": {k: v[idx] for k, v in self.obs.items()}, "next_obs": {k: v[nxt] for k, v in self.obs.items()},
                "actions": self.actions[idx], "rewards": self.rewards[idx], "terminated": self.terminated[idx]}


def flat_dim(dims: dict[str, Any]) -> int:
    return int(dims["flat_dim"])


class DDQNActor:
    """Epsilon-greedy action selection with the shared Q-network (one forward pass per step)."""

    obs_format = "flat"
    snapshot_fields: tuple[str, ...] = ()  # the observations are all it reads

    def __init__(self, config: dict[str, Any], dims: dict[str, Any]):
        self.config = DDQNConfig(**config)
        self.q = QNetwork(flat_dim(dims), int(dims["n_actions"]), self.config.hidden)
        self.q.eval()

    def set_weights(self, weights: dict[str, np.ndarray]) -> None:
        load_numpy_state(self.q, weights)

    def act(self, result: StepResult, snapshot: TrafficSnapshot | None, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput:
        return self.act_many([result], [snapshot], [rng], explore)[0]

    def act_many(self, results: list[StepResult], snapshots: list[Any], rngs: list[np.random.Generator],
                 explore: dict[str, Any]) -> list[ActOutput]:
        """One forward pass over the aircraft of every episode; each episode explores with its own generator."""
        flats = [r.obs.flat for r in results]
        assert all(f is not None for f in flats), "DQN needs obs_format='flat'"
        obs = np.concatenate(flats) if len(flats) > 1 else flats[0]  # type: ignore[arg-type]
        with torch.no_grad():
            q_all = self.q(torch.from_numpy(obs)).numpy()
        eps = float(explore.get("epsilon", 0.0))
        outs = []
        start = 0
        for r, rng in zip(results, rngs):
            q = q_all[start:start + len(r.agents)]
            start += len(r.agents)
            actions = q.argmax(axis=1)
            if eps > 0:
                rand = rng.random(len(actions)) < eps
                actions = np.where(rand, rng.integers(0, q.shape[1], size=len(actions)), actions)
            outs.append(ActOutput(actions, None, q.max(axis=1)))
        return outs


class DDQNLearner:
    """Replay memory, online and target Q-networks, and the gradient steps."""

    obs_format = "flat"

    def __init__(self, config: dict[str, Any], dims: dict[str, Any], device: str = "cpu", seed: int = 0,
                 static: bool | None = None):
        """``static``: the replay on the device and a fixed-shape gradient step (captured in a CUDA graph
        on a GPU, see the module docstring); None: on CUDA only. The CPU keeps the numpy replay."""
        self.config = DDQNConfig(**config)
        self.dims = dict(dims)
        self.device = check_device(device)
        torch.manual_seed(seed)
        n_act = int(dims["n_actions"])
        self.q = QNetwork(flat_dim(dims), n_act, self.config.hidden).to(self.device)
        self.q_target = QNetwork(flat_dim(dims), n_act, self.config.hidden).to(self.device)
        self.q_target.load_state_dict(self.q.state_dict())
        self.static = self.device.type == "cuda" if static is None else bool(static)
        params = list(self.q.parameters())
        self.optimizer = static_optimizer(params, self.device, self.config.lr, 1e-8) if self.static \
            else torch.optim.Adam(params, lr=self.config.lr)
        self.memory: ReplayMemory | DeviceReplay = DeviceReplay(self.config.replay_size, self.device, seed) \
            if self.static else ReplayMemory(self.config.replay_size)
        self.rng = np.random.default_rng(seed)
        if self.static:
            b, dev = self.config.batch_size, self.device
            self._batch: dict[str, Any] = {  # the captured step's inputs (filled on the device each step)
                "obs": {"flat": torch.zeros((b, flat_dim(dims)), device=dev)},
                "next_obs": {"flat": torch.zeros((b, flat_dim(dims)), device=dev)},
                "actions": torch.zeros(b, dtype=torch.int64, device=dev), "rewards": torch.zeros(b, device=dev),
                "terminated": torch.zeros(b, dtype=torch.bool, device=dev)}
            self._loss_sum = torch.zeros((), dtype=torch.float64, device=dev)
            self._step = CapturedStep(self._static_step, params, self.optimizer, capture=dev.type == "cuda")
        self.epsilon = LinearSchedule(self.config.eps_start, self.config.eps_end, self.config.eps_decay_steps)
        self.transitions = 0  # aircraft transitions collected so far
        self.env_steps = 0  # environment steps collected so far
        self.step_credit = 0.0  # per_transition: transitions not yet paid for by a gradient step
        self.gradient_steps = 0
        self.last_sync = 0  # the count (env steps or transitions, as the schedule counts) at the last target copy

    # -------------------------------------------------------------- worker side
    def actor_spec(self, kind: str) -> dict[str, Any]:
        return {"kind": kind, "config": asdict(self.config), "dims": self.dims}

    def weights(self) -> dict[str, np.ndarray]:
        return to_numpy_state(self.q)

    def explore(self, transitions: int, env_steps: int = 0) -> dict[str, Any]:
        """Epsilon after ``transitions`` aircraft transitions / ``env_steps`` environment steps collected."""
        return {"epsilon": self.epsilon(env_steps if self.config.schedule == "rllib" else transitions)}

    def _count(self) -> int:
        return self.env_steps if self.config.schedule == "rllib" else self.transitions

    def eval_explore(self) -> dict[str, Any]:
        return {"epsilon": 0.0}

    # ------------------------------------------------------------------ update
    def targets(self, sample: dict[str, Any]) -> torch.Tensor:
        """One-step targets of a sample: Double-DQN or DQN (see :mod:`rlbridge.agents.core`)."""
        dev = self.device
        return self._targets(torch.as_tensor(sample["next_obs"]["flat"], device=dev),
                             torch.as_tensor(sample["rewards"], device=dev),
                             torch.as_tensor(sample["terminated"], device=dev))

    def _targets(self, nxt: torch.Tensor, rewards: torch.Tensor, term: torch.Tensor) -> torch.Tensor:
        c = self.config
        with torch.no_grad():
            q_next_target = self.q_target(nxt)
            if c.double:
                return ddqn_target(rewards, self.q(nxt), q_next_target, term, c.gamma)
            return dqn_target(rewards, q_next_target, term, c.gamma)

    def td_loss(self, sample: dict[str, Any]) -> torch.Tensor:
        """Huber loss between Q(s, a) and the targets."""
        dev = self.device
        return self._td_loss(torch.as_tensor(sample["obs"]["flat"], device=dev),
                             torch.as_tensor(sample["actions"], device=dev),
                             torch.as_tensor(sample["next_obs"]["flat"], device=dev),
                             torch.as_tensor(sample["rewards"], device=dev),
                             torch.as_tensor(sample["terminated"], device=dev))

    def _td_loss(self, obs: torch.Tensor, actions: torch.Tensor, nxt: torch.Tensor, rewards: torch.Tensor,
                 term: torch.Tensor) -> torch.Tensor:
        q = self.q(obs).gather(1, actions.unsqueeze(1)).squeeze(1)
        return nn.functional.smooth_l1_loss(q, self._targets(nxt, rewards, term))

    def _static_step(self) -> None:
        """The gradient step on ``self._batch`` (what the CUDA graph records): no zero_grad, no host read."""
        s = self._batch
        loss = self._td_loss(s["obs"]["flat"], s["actions"], s["next_obs"]["flat"], s["rewards"], s["terminated"])
        loss.backward()
        nn.utils.clip_grad_norm_(self.q.parameters(), self.config.max_grad_norm)
        self.optimizer.step()
        self._loss_sum += loss.detach().to(self._loss_sum.dtype)

    def update(self, batches: list[EpisodeBatch]) -> dict[str, float]:
        """Store the episodes, then the gradient steps (and target copies) their counts call for."""
        new = env_new = 0
        for b in batches:
            self.memory.add(b)
            new += len(b)
            env_new += int(b.stats.env_steps)
        start_tr, start_env = self.transitions, self.env_steps
        self.transitions += new
        self.env_steps += env_new
        marks = self._step_marks(start_tr, start_env)
        losses = []
        if self.static and marks:
            self._loss_sum.zero_()
        for mark in marks:
            if self.static:
                assert isinstance(self.memory, DeviceReplay)
                self.memory.gather(self.memory.sample_slots(self.config.batch_size), self._batch)
                if self._step.prepare():  # the first step records the graph (CUDA) from this batch
                    self._loss_sum.zero_()
                self._step()
                self.gradient_steps += 1
            else:
                assert isinstance(self.memory, ReplayMemory)
                losses.append(self.gradient_step(self.memory.sample(self.config.batch_size, self.rng)))
            if mark - self.last_sync >= self.config.target_update:
                self.q_target.load_state_dict(self.q.state_dict())  # in place: a captured step stays valid
                self.last_sync = int(mark)
        out = {"epsilon": self.epsilon(self._count()), "gradient_steps": float(self.gradient_steps),
               "replay_rows": float(self.memory.size)}
        if marks:  # one device read per update
            out["td_loss"] = float(self._loss_sum) / len(marks) if self.static \
                else float(torch.stack(losses).double().mean())
        elif self._count() >= self.config.learning_starts:
            out["td_loss"] = float("nan")
        return out

    def _step_marks(self, start_tr: int, start_env: int) -> list[float]:
        """The counts (as the schedule counts) at which this update's gradient steps fall, ascending."""
        c = self.config
        if c.schedule == "rllib":
            return [float(m) for m in rllib_step_marks(start_env, self.env_steps, c.env_steps_per_gradient_step,
                                                       c.learning_starts)]
        if self.transitions < c.learning_starts:
            return []
        self.step_credit += self.transitions - max(start_tr, c.learning_starts)
        steps = int(self.step_credit // c.train_freq)
        self.step_credit -= steps * c.train_freq
        # Target copies at the transition counts they belong to, spread over this iteration's steps.
        return [start_tr + (k + 1) * (self.transitions - start_tr) / max(steps, 1) for k in range(steps)]

    def gradient_step(self, sample: dict[str, Any]) -> torch.Tensor:
        """One Adam step on the Huber TD loss of ``sample``; returns the loss (0-d, detached, on the device)."""
        loss = self.td_loss(sample)
        self.optimizer.zero_grad()
        loss.backward()
        nn.utils.clip_grad_norm_(self.q.parameters(), self.config.max_grad_norm)
        self.optimizer.step()
        self.gradient_steps += 1
        return loss.detach()

    # ------------------------------------------------------------- checkpoints
    def state_dict(self) -> dict[str, Any]:
        """Networks, optimiser and counters (the replay memory is not saved: it would take GBs)."""
        extra = {"device_rng": self.memory.gen.get_state()} if isinstance(self.memory, DeviceReplay) else {}
        return {**extra, "model": self.q.state_dict(), "target": self.q_target.state_dict(),
                "optimizer": self.optimizer.state_dict(), "rng": self.rng.bit_generator.state,
                "transitions": self.transitions, "env_steps": self.env_steps, "step_credit": self.step_credit,
                "gradient_steps": self.gradient_steps, "last_sync": self.last_sync}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.q.load_state_dict(state["model"])
        self.q_target.load_state_dict(state["target"])
        load_optimizer_state(self.optimizer, state["optimizer"])
        self.rng.bit_generator.state = state["rng"]
        if isinstance(self.memory, DeviceReplay) and "device_rng" in state:
            self.memory.gen.set_state(state["device_rng"])
        self.transitions = int(state["transitions"])
        self.env_steps = int(state.get("env_steps", 0))  # checkpoints before the rllib schedule: none counted
        self.step_credit = float(state["step_credit"])
        self.gradient_steps = int(state["gradient_steps"])
        self.last_sync = int(state["last_sync"])
