"""Per-step cost of publishing the heading / altitude action targets, with a learner acting.

Before issue 29 the episode engine computed every action's targets at each reset and step of a
heading or altitude use case, whatever the acting policy; now only while an actor that reads
them plays (``reads_action_targets``: ``mvp``). This plays the same episodes with a DQN learner
acting (greedy, fresh weights) twice, alternating in one process: ``old`` publishes the targets
at every step (what the engine did for everyone), ``new`` as a learner gets them now (not at all).

    python bench/bench_action_targets.py --scenario nyc_train_100 --time-limit 1800 --rounds 3

Prints the wall time per environment step [ms] (the engine's reset/step, the actor's forward
pass included) per variant, the median over the rounds, and the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics

from rlbridge.agents import make_learner, usecase_dims
from rlbridge.agents.rollout import EnvSpec, RolloutWorker

USECASE = "heading_altitude_sa"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="nyc_train_100")
    ap.add_argument("--time-limit", type=float, default=1800.0, help="episode limit [s of sim time]")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    learner = make_learner("dqn", {}, usecase_dims(USECASE, {}), seed=0)
    worker = RolloutWorker(EnvSpec(args.scenario, USECASE, {}, time_limit_s=args.time_limit),
                           {"policy": learner.actor_spec("dqn")}, torch_threads=1)
    worker.set_weights(learner.weights())
    actor = worker.actors["policy"]
    worker.collect([args.seed], explore={"epsilon": 0.0}, record=False)  # warm-up (compilation)
    per_step: dict[str, list[float]] = {"old": [], "new": []}
    steps = 0
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    for _ in range(args.rounds):
        for variant in ("old", "new"):
            # old: the targets at every step, as the engine published them for every policy before.
            actor.reads_action_targets = variant == "old"  # type: ignore[attr-defined]
            stats = worker.collect([args.seed], explore={"epsilon": 0.0}, record=False)[0]
            steps = stats.env_steps
            per_step[variant].append(1e3 * stats.wall_s / max(stats.env_steps, 1))
    old, new = statistics.median(per_step["old"]), statistics.median(per_step["new"])
    print(f"{USECASE} on {args.scenario} ({args.time_limit:g} s sim, {steps} steps, DQN acting): "
          f"old {old:.3f} ms/step -> new {new:.3f} ms/step ({100 * (new - old) / old:+.1f} %)")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
