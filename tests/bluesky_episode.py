"""Run corridor_sa episodes on the BlueSky backend and save what the agents saw (used by the tests).

Usage: python bluesky_episode.py SCENARIO.scn OUT.npz

BlueSky keeps process-wide state, so the tests run this in a subprocess. The
actions are fixed (ACTIONS below); per decision the file holds the agents, the
observations and rewards the environment returned, and BlueSky's own
positions next to the mirror's after the step.
"""

from __future__ import annotations

import json
import sys

import numpy as np

ACTIONS = [{"TA1": 2, "TB2": 2}, {"TA1": 1, "TB2": 2}, {"TA1": 2, "TB2": 0}, {"TA1": 0, "TB2": 1}, {"TA1": 1, "TB2": 2}, {}, {}]


def main() -> None:
    import rlbridge

    scenario, out = sys.argv[1], sys.argv[2]
    env = rlbridge.parallel_env(scenario, backend="bluesky", time_limit_s=600.0, n_intruders=4)
    obs, _ = env.reset(seed=0)
    arrays: dict[str, np.ndarray] = {}
    agents: list[list[str]] = [list(obs)]
    arrays["obs0"] = np.array([obs[a] for a in obs])
    for k, actions in enumerate(ACTIONS, start=1):
        obs, rewards, _, _, _ = env.step(actions)
        agents.append(list(obs))
        arrays[f"obs{k}"] = np.array([obs[a] for a in obs])
        arrays[f"rew{k}"] = np.array([rewards[a] for a in obs])
        state = env.core.bluesky_state()
        view = env.core.sim.view
        order = [state["ids"].index(a) for a in view.ids]
        arrays[f"bs_lat{k}"], arrays[f"mirror_lat{k}"] = state["lat"][order], np.array(view.lat)
        arrays[f"bs_selspd{k}"] = np.array(env.core.bs.traf.selspd)[order]
    np.savez(out, agents=json.dumps(agents), **arrays)
    env.close()


if __name__ == "__main__":
    main()
