"""Train Stable-Baselines3 PPO on the single-aircraft environment ``aamgym/CorridorSA-v1``.

    python examples/sb3_ppo.py --scenario merge_conflict --steps 5000
    python examples/sb3_ppo.py --scenario nyc_train_100 --ego UAM0950 --steps 200000

One aircraft (``ego``; by default each reset draws it from the scenario's aircraft, with the
reset's seed) is controlled; the other aircraft fly their flight plans (unequipped) unless
``traffic_policy`` says otherwise. The scenarios named here are shipped with aamsim, so the
example runs from any folder; it needs the ``rl`` extra (``pip install "aamsim[rl]"``).
"""

from __future__ import annotations

import argparse
import sys

import gymnasium as gym

import rlbridge
from aamsim.extras import MissingExtra, require


def train(scenario: str, steps: int, seed: int = 0, ego: str | None = None, algo: str = "ppo",
          time_limit_s: float | None = 600.0):
    from stable_baselines3 import DQN, PPO

    env = gym.make(rlbridge.ENV_ID, scenario=scenario, ego=ego, time_limit_s=time_limit_s)
    if algo == "ppo":
        model = PPO("MlpPolicy", env, n_steps=256, batch_size=64, seed=seed, verbose=0, device="cpu")
    else:
        model = DQN("MlpPolicy", env, learning_starts=200, buffer_size=10_000, train_freq=4,
                    exploration_fraction=0.5, seed=seed, verbose=0, device="cpu")
    model.learn(total_timesteps=steps)
    return model, env


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--scenario", default="merge_conflict", help="a .scn file or a shipped scenario's name")
    ap.add_argument("--steps", type=int, default=5000, help="environment steps to train for")
    ap.add_argument("--ego", default=argparse.SUPPRESS,
                    help="callsign of the controlled aircraft (default: drawn at each reset)")
    ap.add_argument("--algo", choices=("ppo", "dqn"), default="ppo", help="Stable-Baselines3 algorithm")
    args = ap.parse_args()
    try:
        require("rl", "examples/sb3_ppo.py", ("stable_baselines3", "torch"))
    except MissingExtra as exc:
        sys.exit(f"error: {exc}")
    model, env = train(args.scenario, args.steps, ego=getattr(args, "ego", None), algo=args.algo)
    obs, _ = env.reset(seed=123)
    total, done = 0.0, False
    while not done:
        action, _ = model.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, _ = env.step(action)
        total += float(reward)
        done = terminated or truncated
    print(f"greedy episode return of the ego aircraft: {total:.3f}")


if __name__ == "__main__":
    main()
