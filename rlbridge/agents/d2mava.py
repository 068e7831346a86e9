"""D2MAV-A: PPO with attention over intruders (Brittain & Wei), shared or separate actor-critic.

Deep Distributed Multi-Agent Variable-agent with Attention: one policy shared by every
aircraft (decentralised execution, centralised learning on all agents' transitions), whose
network summarises a variable number of intruders with attention:

    h_o = LeakyReLU(W_own s_o)                        ownship encoder (128)
    h_i = LeakyReLU(W_int s_i)                        per-intruder encoder (128), same weights for all i
    e_i = (W_q h_o) . h_i / sqrt(128)                 scaled dot-product score of intruder i (Vaswani et al.)
    a   = softmax over the *valid* intruders of e     padded intruders get weight 0;
    c   = sum_i a_i h_i                               no valid intruder -> c = 0
    z   = LeakyReLU(W_2 LeakyReLU(W_1 [h_o, c]))      two 128-unit layers
    pi(a | s) = softmax(W_pi z),  V(s) = w_v^T z

``shared=True`` (D2MAV-A "Shared Layers", as introduced by Brittain & Wei) has the actor and
the critic share encoders, attention and trunk; ``shared=False`` ("No Shared Layers", the
paper's best) gives each its own copy. Training is PPO (Schulman et al. 2017) with GAE
over each aircraft's own chain of decisions. Defaults are the paper's D2MAV-A table.
Advantages are normalised per minibatch (a documented choice, not in the paper).
"""

from __future__ import annotations

import logging
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import nn

from rlbridge.agents.capture import check_device, host_to_device, load_optimizer_state, static_optimizer
from rlbridge.agents.core import (
    PackedIntruders,
    attention_pool,
    compute_gae,
    minibatch_bounds,
    normalize,
    ppo_clip_loss,
    segment_attention_pool,
    value_loss,
)
from rlbridge.agents.rollout import ActOutput, EpisodeBatch
from rlbridge.agents.static_ppo import StaticPPO
from rlbridge.core import StepResult

if TYPE_CHECKING:
    from aamsim.snapshots import TrafficSnapshot

log = logging.getLogger("rlbridge.d2mava")


@dataclass
class D2MAVAConfig:
    """PPO + attention hyper-parameters (paper's Table "D2MAV-A Hyperparameters" as defaults)."""

    shared: bool = False  # share encoder/attention/trunk between actor and critic
    lr: float = 1e-5
    batch_size: int = 512  # minibatch size [transitions]
    epochs: int = 6
    ent_coef: float = 1e-4  # entropy coefficient beta
    clip: float = 0.1  # PPO ratio bound epsilon
    hidden: int = 128  # nodes per layer
    gamma: float = 0.99
    lam: float = 0.95  # GAE lambda
    leaky_slope: float = 0.2  # LeakyReLU alpha
    vf_coef: float = 0.5  # value-loss weight (not in the paper)
    max_grad_norm: float = 0.5  # gradient clipping (not in the paper)
    norm_adv: bool = True  # per-minibatch advantage normalisation (not in the paper)
    greedy_eval: bool = True  # frozen evaluation picks the most likely action (False: sample)
    # Implementation, not a hyper-parameter: the update runs the attention on the valid intruders
    # only (same loss and gradients up to float rounding, 2.4x faster on nyc_train_100); false: padded.
    packed_attention: bool = True


class AttentionEncoder(nn.Module):
    """Ownship + attention-pooled intruders -> a ``hidden``-dim feature (see the module docstring)."""

    def __init__(self, own_dim: int, intr_dim: int, hidden: int, slope: float):
        super().__init__()
        self.own = nn.Sequential(nn.Linear(own_dim, hidden), nn.LeakyReLU(slope))
        self.intr = nn.Sequential(nn.Linear(intr_dim, hidden), nn.LeakyReLU(slope))
        self.query = nn.Linear(hidden, hidden, bias=False)
        self.scale = 1.0 / float(hidden) ** 0.5
        self.trunk = nn.Sequential(nn.Linear(2 * hidden, hidden), nn.LeakyReLU(slope),
                                   nn.Linear(hidden, hidden), nn.LeakyReLU(slope))

    def forward(self, own: torch.Tensor, intr: torch.Tensor, mask: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor]:
        """own (B, Do), intr (B, N, Di), mask (B, N) -> features (B, H), attention weights (B, N)."""
        ho = self.own(own)
        hi = self.intr(intr)
        # The query is projected once per ownship; a key projection per intruder would cost
        # N times more and the per-intruder encoder already learns the keys.
        scores = torch.einsum("bh,bnh->bn", self.query(ho), hi) * self.scale
        context, weights = attention_pool(hi, scores, mask)
        return self.trunk(torch.cat([ho, context], dim=-1)), weights

    def forward_packed(self, own: torch.Tensor, rows: torch.Tensor, seg: torch.Tensor) -> torch.Tensor:
        """:meth:`forward` on packed valid intruders (``rows`` (K, Di) of ownship ``seg``): same features."""
        ho = self.own(own)
        hi = self.intr(rows)
        scores = (self.query(ho).index_select(0, seg) * hi).sum(dim=-1) * self.scale
        context, _ = segment_attention_pool(hi, scores, seg, own.shape[0])
        return self.trunk(torch.cat([ho, context], dim=-1))

    def forward_static(self, own: torch.Tensor, rows: torch.Tensor, seg: torch.Tensor) -> torch.Tensor:
        """:meth:`forward_packed` where ``seg`` may also be ``len(own)``: padding rows of a fixed-size
        gather (:meth:`~rlbridge.agents.core.PackedIntruders.gather_static`), pooled as an extra ownship
        that is dropped; they change neither the features nor the gradients of the real ones."""
        ho = self.own(own)
        hi = self.intr(rows)
        q = self.query(ho)
        q = torch.cat([q, q.new_zeros(1, q.shape[1])])
        scores = (q.index_select(0, seg) * hi).sum(dim=-1) * self.scale
        context, _ = segment_attention_pool(hi, scores, seg, own.shape[0] + 1)
        return self.trunk(torch.cat([ho, context[:-1]], dim=-1))


class ActorCritic(nn.Module):
    """Policy logits and state value from (ownship, intruders, mask)."""

    def __init__(self, own_dim: int, intr_dim: int, n_actions: int, cfg: D2MAVAConfig):
        super().__init__()
        self.shared = cfg.shared
        self.actor_enc = AttentionEncoder(own_dim, intr_dim, cfg.hidden, cfg.leaky_slope)
        self.critic_enc = None if cfg.shared else AttentionEncoder(own_dim, intr_dim, cfg.hidden, cfg.leaky_slope)
        self.pi = nn.Linear(cfg.hidden, n_actions)
        self.v = nn.Linear(cfg.hidden, 1)
        # A near-uniform initial policy (small last-layer weights), as usual for PPO.
        nn.init.orthogonal_(self.pi.weight, gain=0.01)
        nn.init.zeros_(self.pi.bias)
        nn.init.orthogonal_(self.v.weight, gain=1.0)
        nn.init.zeros_(self.v.bias)

    def clip_groups(self) -> list[list[nn.Parameter]]:
        """The parameter groups whose gradient norm is clipped on its own: actor and critic when they
        are separate networks (one joint clip would let the critic's large value gradients shrink the
        actor's step), everything together when they share layers."""
        if self.critic_enc is None:
            return [list(self.parameters())]
        return [[*self.actor_enc.parameters(), *self.pi.parameters()],
                [*self.critic_enc.parameters(), *self.v.parameters()]]

    def forward(self, own: torch.Tensor, intr: torch.Tensor, mask: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor]:
        za, _ = self.actor_enc(own, intr, mask)
        zc = za if self.critic_enc is None else self.critic_enc(own, intr, mask)[0]
        return self.pi(za), self.v(zc).squeeze(-1)

    def forward_packed(self, own: torch.Tensor, rows: torch.Tensor, seg: torch.Tensor
                       ) -> tuple[torch.Tensor, torch.Tensor]:
        """:meth:`forward` with packed intruders (:class:`~rlbridge.agents.core.PackedIntruders`)."""
        za = self.actor_enc.forward_packed(own, rows, seg)
        zc = za if self.critic_enc is None else self.critic_enc.forward_packed(own, rows, seg)
        return self.pi(za), self.v(zc).squeeze(-1)

    def forward_static(self, own: torch.Tensor, rows: torch.Tensor, seg: torch.Tensor
                       ) -> tuple[torch.Tensor, torch.Tensor]:
        """:meth:`forward_packed` on a fixed-size gather (:meth:`AttentionEncoder.forward_static`)."""
        za = self.actor_enc.forward_static(own, rows, seg)
        zc = za if self.critic_enc is None else self.critic_enc.forward_static(own, rows, seg)
        return self.pi(za), self.v(zc).squeeze(-1)


def obs_dims(spec_dims: dict[str, Any]) -> tuple[int, int]:
    """Ownship and intruder feature sizes of an ownship-plus-intruders observation; another is refused."""
    if "own_dim" not in spec_dims or "intruder_dim" not in spec_dims:
        # D2MAV-A attends over intruders: a flat observation (e.g. reach_destination's) has none to read.
        raise ValueError("D2MAV-A needs an observation of an ownship and its intruders (obs_format 'ownship'); "
                         f"this use case gives {sorted(spec_dims)}: train it with algorithm=ddqn instead")
    return int(spec_dims["own_dim"]), int(spec_dims["intruder_dim"])


def to_numpy_state(model: nn.Module) -> dict[str, np.ndarray]:
    """A model's weights as numpy arrays (what goes to the workers)."""
    return {k: v.detach().cpu().numpy().copy() for k, v in model.state_dict().items()}


def load_numpy_state(model: nn.Module, weights: dict[str, np.ndarray]) -> None:
    model.load_state_dict({k: torch.tensor(np.array(v)) for k, v in weights.items()})


def sample_categorical(logits: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Draw one action per row from softmax(logits) with a numpy Generator; returns (actions, log-probs)."""
    z = logits - logits.max(axis=1, keepdims=True)
    logp_all = z - np.log(np.exp(z).sum(axis=1, keepdims=True))
    cdf = np.cumsum(np.exp(logp_all), axis=1)
    u = rng.random(len(logits))[:, None] * cdf[:, -1:]
    actions = np.minimum((u > cdf).sum(axis=1), logits.shape[1] - 1)
    return actions, logp_all[np.arange(len(actions)), actions]


class D2MAVAActor:
    """The acting half, run in rollout workers: one batched forward pass per decision step."""

    obs_format = "dict"
    snapshot_fields: tuple[str, ...] = ()  # the observations are all it reads

    def __init__(self, config: dict[str, Any], dims: dict[str, Any]):
        self.config = D2MAVAConfig(**config)
        own_dim, intr_dim = obs_dims(dims)
        self.model = ActorCritic(own_dim, intr_dim, int(dims["n_actions"]), self.config)
        self.model.eval()

    def set_weights(self, weights: dict[str, np.ndarray]) -> None:
        load_numpy_state(self.model, weights)

    def act(self, result: StepResult, snapshot: TrafficSnapshot | None, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput:
        return self.act_many([result], [snapshot], [rng], explore)[0]

    def act_many(self, results: list[StepResult], snapshots: list[Any], rngs: list[np.random.Generator],
                 explore: dict[str, Any]) -> list[ActOutput]:
        """One forward pass over the aircraft of every episode; each episode samples with its own generator."""
        parts = [r.obs.parts for r in results]
        assert all(p is not None for p in parts), "D2MAV-A needs obs_format='dict'"
        cat = {k: np.concatenate([p[k] for p in parts]) if len(parts) > 1 else parts[0][k]  # type: ignore[index]
               for k in ("ownship", "intruders", "mask")}
        with torch.no_grad():
            logits, values = self.model(torch.from_numpy(cat["ownship"]), torch.from_numpy(cat["intruders"]),
                                        torch.from_numpy(cat["mask"]))
        lg_all, v_all = logits.numpy().astype(np.float64), values.numpy()
        outs = []
        start = 0
        for r, rng in zip(results, rngs):
            end = start + len(r.agents)
            lg = lg_all[start:end]
            if explore.get("greedy", False):
                actions = lg.argmax(axis=1)
                z = lg - lg.max(axis=1, keepdims=True)
                logp = (z - np.log(np.exp(z).sum(axis=1, keepdims=True)))[np.arange(len(actions)), actions]
            else:
                actions, logp = sample_categorical(lg, rng)
            outs.append(ActOutput(actions, logp.astype(np.float32), v_all[start:end]))
            start = end
        return outs


class D2MAVALearner:
    """PPO updates of the attention actor-critic on whole episodes of every agent."""

    obs_format = "dict"

    def __init__(self, config: dict[str, Any], dims: dict[str, Any], device: str = "cpu", seed: int = 0,
                 static: bool | None = None):
        """``static``: the fixed-shape update of :mod:`rlbridge.agents.static_ppo` (captured in a CUDA
        graph on a GPU); None: on CUDA only. The eager update stays the CPU's: same losses, no padding."""
        self.config = D2MAVAConfig(**config)
        self.dims = dict(dims)
        self.device = check_device(device)
        own_dim, intr_dim = obs_dims(dims)
        torch.manual_seed(seed)
        self.model = ActorCritic(own_dim, intr_dim, int(dims["n_actions"]), self.config).to(self.device)
        use_static = self.device.type == "cuda" if static is None else bool(static)
        if use_static and not self.config.packed_attention:
            log.info("packed_attention=false: the eager update (the static one gathers packed intruders)")
            use_static = False
        params = list(self.model.parameters())
        self.optimizer = static_optimizer(params, self.device, self.config.lr, 1e-5) if use_static \
            else torch.optim.Adam(params, lr=self.config.lr, eps=1e-5)
        self.clip_groups = self.model.clip_groups()
        self.gen = torch.Generator().manual_seed(seed)
        self.updates = 0
        self.static = StaticPPO(self, capture=self.device.type == "cuda") if use_static else None

    # -------------------------------------------------------------- worker side
    def actor_spec(self, kind: str) -> dict[str, Any]:
        return {"kind": kind, "config": asdict(self.config), "dims": self.dims}

    def weights(self) -> dict[str, np.ndarray]:
        return to_numpy_state(self.model)

    def explore(self, transitions: int, env_steps: int = 0) -> dict[str, Any]:
        return {"greedy": False}

    def eval_explore(self) -> dict[str, Any]:
        return {"greedy": self.config.greedy_eval}

    # ------------------------------------------------------------------ update
    def prepare(self, batches: list[EpisodeBatch]) -> dict[str, np.ndarray]:
        """Concatenate the episodes' transitions with GAE advantages and value targets."""
        c = self.config
        cols: dict[str, list[np.ndarray]] = {k: [] for k in ("ownship", "intruders", "mask", "actions", "logp",
                                                              "adv", "ret", "values")}
        for b in batches:
            if len(b) == 0:
                continue
            next_t, ends = b.chains()
            adv, ret = compute_gae(b.rewards, b.values[b.obs_idx], b.values[b.next_idx], b.terminated, ends,
                                   c.gamma, c.lam, next_index=next_t)
            for k in ("ownship", "intruders", "mask"):
                cols[k].append(b.obs[k][b.obs_idx])
            cols["actions"].append(b.actions)
            cols["logp"].append(b.logp)
            cols["adv"].append(adv.astype(np.float32))
            cols["ret"].append(ret.astype(np.float32))
            cols["values"].append(b.values[b.obs_idx])
        return {k: np.concatenate(v) if v else np.zeros(0, np.float32) for k, v in cols.items()}

    def update(self, batches: list[EpisodeBatch]) -> dict[str, float]:
        """``epochs`` passes of minibatch PPO over the transitions of ``batches``."""
        data = self.prepare(batches)
        if len(data["actions"]) == 0:
            return {}
        self.model.train()
        totals, steps = self.static.update(data) if self.static is not None else self._update_eager(data)
        self.model.eval()
        names = ("policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction")
        ret, val = data["ret"], data["values"]
        var = float(np.var(ret))
        out = dict(zip(names, (totals / max(steps, 1)).tolist()))  # the one device read of the update
        out["explained_variance"] = float(1.0 - np.var(ret - val) / var) if var > 0 else 0.0
        out["gradient_steps"] = float(self.updates)
        return out

    def _update_eager(self, data: dict[str, np.ndarray]) -> tuple[torch.Tensor, int]:
        """The eager update: summed losses (a device tensor, read once by the caller) and gradient steps."""
        c = self.config
        n = len(data["actions"])
        t = {k: host_to_device(v, self.device) for k, v in data.items()}
        packed = PackedIntruders.from_padded(t["intruders"], t["mask"]) if c.packed_attention else None
        totals = torch.zeros(5, dtype=torch.float64, device=self.device)
        steps = 0
        for _ in range(c.epochs):
            perm = torch.randperm(n, generator=self.gen).to(self.device)
            for start, end in minibatch_bounds(n, c.batch_size):
                self.minibatch_step(t, packed, perm[start:end], totals)
                self.updates += 1
                steps += 1
        return totals, steps

    def minibatch_step(self, t: dict[str, torch.Tensor], packed: PackedIntruders | None, idx: torch.Tensor,
                       totals: torch.Tensor) -> None:
        """One eager gradient step on the transitions ``idx`` of ``t``; adds its losses to ``totals``
        (policy loss, value loss, entropy, approx. KL, clip fraction)."""
        c = self.config
        if packed is not None:
            rows, seg = packed.gather(idx)
            logits, values = self.model.forward_packed(t["ownship"][idx], rows, seg)
        else:
            logits, values = self.model(t["ownship"][idx], t["intruders"][idx], t["mask"][idx])
        dist = torch.distributions.Categorical(logits=logits)
        logp = dist.log_prob(t["actions"][idx])
        adv = normalize(t["adv"][idx]) if c.norm_adv else t["adv"][idx]
        pl, info = ppo_clip_loss(logp, t["logp"][idx], adv, c.clip)
        vl = value_loss(values, t["ret"][idx])
        ent = dist.entropy().mean()
        loss = pl + c.vf_coef * vl - c.ent_coef * ent
        self.optimizer.zero_grad()
        loss.backward()
        for group in self.clip_groups:
            nn.utils.clip_grad_norm_(group, c.max_grad_norm)
        self.optimizer.step()
        totals += torch.stack([pl.detach(), vl.detach(), ent.detach(), info.approx_kl,
                               info.clip_fraction]).to(totals.dtype)

    # ------------------------------------------------------------- checkpoints
    def state_dict(self) -> dict[str, Any]:
        return {"model": self.model.state_dict(), "optimizer": self.optimizer.state_dict(),
                "gen": self.gen.get_state(), "updates": self.updates}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.model.load_state_dict(state["model"])
        load_optimizer_state(self.optimizer, state["optimizer"])
        self.gen.set_state(state["gen"])
        self.updates = int(state["updates"])
