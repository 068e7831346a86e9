"""Train RLlib's PPO (new API stack) on the multi-agent corridor environment.

    python examples/rllib_ppo.py --scenario merge_conflict --iterations 2
    python examples/rllib_ppo.py --scenario nyc_train_100 --iterations 100 --env-runners 2

Every aircraft maps to one shared policy (parameter sharing, as D2MAV-A does). RLlib's
default model takes flat Box observations, hence ``obs_format="flat"``. The scenarios named here
are shipped with aamsim; the example needs the ``rl`` extra (``pip install "aamsim[rl]"``).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from aamsim.extras import MissingExtra, require


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--scenario", default="merge_conflict", help="a .scn file or a shipped scenario's name")
    ap.add_argument("--iterations", type=int, default=2, help="RLlib training iterations")
    ap.add_argument("--env-runners", type=int, default=0,
                    help="RLlib env-runner processes (0: sample in the driver)")
    ap.add_argument("--time-limit-s", type=float, default=600.0, help="episode length in sim seconds")
    args = ap.parse_args()
    try:
        require("rl", "examples/rllib_ppo.py", ("ray", "torch"))
    except MissingExtra as exc:
        sys.exit(f"error: {exc}")
    import ray

    # Ray workers must import this checkout's rlbridge (not needed once the package is installed).
    root = str(Path(__file__).resolve().parent.parent)
    ray.init(num_cpus=max(os.cpu_count() or 1, args.env_runners + 1), include_dashboard=False,
             runtime_env={"env_vars": {"PYTHONPATH": root}})
    from rlbridge.rllib_env import ppo_config

    algo = ppo_config(args.scenario, args.env_runners, time_limit_s=args.time_limit_s).build_algo()
    for i in range(args.iterations):
        result = algo.train()
        runners = result.get("env_runners", {})
        print(f"iteration {i + 1}: episode return mean {runners.get('episode_return_mean')}, "
              f"env steps {runners.get('num_env_steps_sampled_lifetime')}")
    algo.stop()
    ray.shutdown()


if __name__ == "__main__":
    main()
