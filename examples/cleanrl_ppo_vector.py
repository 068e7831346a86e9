"""CleanRL-style PPO (one readable file) on a Gymnasium 1.x vector environment, native or ``SyncVectorEnv``.

    python examples/cleanrl_ppo_vector.py --num-envs 16 --steps 200000            # the native vector env
    python examples/cleanrl_ppo_vector.py --num-envs 16 --steps 20000 --sync       # SyncVectorEnv, for comparison

The loop is CleanRL's ``ppo.py`` for discrete actions, written for Gymnasium 1.x's default
autoreset (``NextStep``): the step after a sub-environment ended returns its first
observation of the next episode, with reward 0 and its action ignored; that step is no
transition, so it is masked out of the advantages and the loss. Nothing in the loop knows
which vector environment it runs on: both give the same episodes for the same seeds, so the
same weights come out (``tests/test_vector_training.py``).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch
from torch import nn

import rlbridge  # noqa: F401  (registers the aamgym ids)


@dataclass
class PPOConfig:
    num_steps: int = 64  # decisions per sub-environment per update
    lr: float = 2.5e-4
    gamma: float = 0.99
    gae_lambda: float = 0.95
    epochs: int = 2
    minibatches: int = 4
    clip: float = 0.2
    ent_coef: float = 0.01
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5


class Agent(nn.Module):
    def __init__(self, obs_dim: int, n_actions: int):
        super().__init__()
        self.critic = nn.Sequential(nn.Linear(obs_dim, 64), nn.Tanh(), nn.Linear(64, 1))
        self.actor = nn.Sequential(nn.Linear(obs_dim, 64), nn.Tanh(), nn.Linear(64, n_actions))

    def value(self, x: torch.Tensor) -> torch.Tensor:
        return self.critic(x).squeeze(-1)

    def act(self, x: torch.Tensor, action: torch.Tensor | None = None):
        dist = torch.distributions.Categorical(logits=self.actor(x))
        if action is None:
            action = dist.sample()
        return action, dist.log_prob(action), dist.entropy(), self.value(x)


def train(envs: gym.vector.VectorEnv, total_steps: int, seed: int = 0,
          cfg: PPOConfig | None = None) -> tuple[Agent, list[float]]:
    """Train PPO for ``total_steps`` sub-environment steps; returns the agent and the episode returns seen."""
    cfg = cfg or PPOConfig()
    torch.manual_seed(seed)
    n = envs.num_envs
    obs_dim = int(np.prod(envs.single_observation_space.shape))
    agent = Agent(obs_dim, int(envs.single_action_space.n))
    optimizer = torch.optim.Adam(agent.parameters(), lr=cfg.lr, eps=1e-5)
    shape = (cfg.num_steps, n)
    obs_buf = torch.zeros((*shape, obs_dim))
    act_buf, logp_buf, rew_buf, done_buf, val_buf, valid_buf = (torch.zeros(shape) for _ in range(6))
    next_obs = torch.as_tensor(envs.reset(seed=seed)[0], dtype=torch.float32)
    next_done = torch.zeros(n)
    autoreset = np.zeros(n, dtype=bool)  # the coming step only resets these (NextStep autoreset)
    returns, running = [], np.zeros(n)
    for _ in range(max(1, total_steps // (cfg.num_steps * n))):
        for t in range(cfg.num_steps):
            obs_buf[t], done_buf[t] = next_obs, next_done
            valid_buf[t] = torch.as_tensor(~autoreset, dtype=torch.float32)
            with torch.no_grad():
                action, logp, _, value = agent.act(next_obs)
            act_buf[t], logp_buf[t], val_buf[t] = action, logp, value
            obs, reward, term, trunc, _ = envs.step(action.numpy())
            rew_buf[t] = torch.as_tensor(reward, dtype=torch.float32)
            running += np.where(autoreset, 0.0, reward)
            ended = term | trunc
            returns += running[ended].tolist()
            running[ended] = 0.0
            autoreset = ended
            next_obs = torch.as_tensor(obs, dtype=torch.float32)
            next_done = torch.as_tensor(term, dtype=torch.float32)  # truncation bootstraps from the value
        with torch.no_grad():
            next_value = agent.value(next_obs)
            adv = torch.zeros(shape)
            last = torch.zeros(n)
            for t in reversed(range(cfg.num_steps)):
                nv = next_value if t == cfg.num_steps - 1 else val_buf[t + 1]
                nd = next_done if t == cfg.num_steps - 1 else done_buf[t + 1]
                delta = rew_buf[t] + cfg.gamma * nv * (1.0 - nd) - val_buf[t]
                last = delta + cfg.gamma * cfg.gae_lambda * (1.0 - nd) * last
                adv[t] = last
            ret = adv + val_buf
        b_obs, b_act, b_logp = obs_buf.reshape(-1, obs_dim), act_buf.reshape(-1), logp_buf.reshape(-1)
        b_adv, b_ret, b_valid = adv.reshape(-1), ret.reshape(-1), valid_buf.reshape(-1)
        idx = np.arange(b_obs.shape[0])
        rng = np.random.default_rng(seed)
        for _ in range(cfg.epochs):
            rng.shuffle(idx)
            for mb in np.array_split(idx, cfg.minibatches):
                _, logp, entropy, value = agent.act(b_obs[mb], b_act[mb].long())
                ratio = (logp - b_logp[mb]).exp()
                a = b_adv[mb]
                a = (a - a.mean()) / (a.std() + 1e-8)
                w = b_valid[mb] / b_valid[mb].sum().clamp(min=1.0)  # autoreset steps are no transitions
                pg = (torch.max(-a * ratio, -a * ratio.clamp(1 - cfg.clip, 1 + cfg.clip)) * w).sum()
                v_loss = (0.5 * (value - b_ret[mb]) ** 2 * w).sum()
                loss = pg - cfg.ent_coef * (entropy * w).sum() + cfg.vf_coef * v_loss
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), cfg.max_grad_norm)
                optimizer.step()
    return agent, returns


def make_envs(env_id: str, num_envs: int, sync: bool, **kwargs) -> gym.vector.VectorEnv:
    mode = "sync" if sync else "vector_entry_point"
    return gym.make_vec(env_id, num_envs=num_envs, vectorization_mode=mode, **kwargs)


def main(argv: list[str] | None = None, make: Callable[..., gym.vector.VectorEnv] = make_envs) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--env-id", default="aamgym/CorridorSA-v1", help="a Gymnasium id of a use case")
    ap.add_argument("--scenario", default="nyc_train_100.scn", help="a .scn file or a shipped scenario's name")
    ap.add_argument("--num-envs", type=int, default=16, help="episodes stepped together")
    ap.add_argument("--steps", type=int, default=20_000, help="environment steps in all (over the sub-environments)")
    ap.add_argument("--interval", type=float, default=1.0, help="decision interval [s]")
    ap.add_argument("--sync", action="store_true", help="gymnasium.vector.SyncVectorEnv instead of the native one")
    ap.add_argument("--seed", type=int, default=0, help="seed of the environments and the network")
    args = ap.parse_args(argv)
    envs = make(args.env_id, args.num_envs, args.sync, scenario=args.scenario, decision_interval_s=args.interval)
    _, returns = train(envs, args.steps, args.seed)
    print(f"{len(returns)} episodes; mean return of the last 20: {np.mean(returns[-20:]) if returns else float('nan'):.3f}")


if __name__ == "__main__":
    main()
