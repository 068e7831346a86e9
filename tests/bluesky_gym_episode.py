"""Run one bluesky-gym environment on BlueSky or on aamsim and save what it returned (used by the tests).

Usage: python bluesky_gym_episode.py ENV_ID {bluesky,aamsim} STEPS SEED OUT.npz [WARMUP]

BlueSky keeps process-wide state, so each side runs in a fresh subprocess. The
actions are fixed (drawn from ``numpy.random.default_rng(SEED)``); the
environments draw their scenarios from Python's and numpy's global generators,
seeded with SEED before the first reset, so both sides see the same traffic.
An episode that ends is followed by a reset, as a training loop does. The file
also holds the time taken by the steps after the first WARMUP (default 0) and
by the start (imports, ``gym.make``, first reset): ``bench/bench_bluesky_gym.py``
reads them.

Two things make BlueSky 1.1.1 run under NumPy 2 here, both on the BlueSky side
only and neither changing what it computes (docs/bluesky-api.md):

* ``Windfield.getdata`` of a single position ends with ``float()`` of a
  one-element array, which NumPy 2 refuses; it is given the position as a
  one-element list and its values returned as floats (what NumPy 1 did).
  ``traf.creconfs`` (HorizontalCREnv, VerticalCREnv) calls it.
* DescentEnv and VerticalCREnv assign their action, an array of shape (1,), to
  an element of a BlueSky array (``bs.traf.selvs[0] = action``), which NumPy 2
  refuses. Both sides get these two environments' actions as 0-d arrays (the
  same numbers; their code only multiplies and compares them).
"""

from __future__ import annotations

import json
import random
import sys
import time

import numpy as np

SCALAR_ACTION_ENVS = ("DescentEnv-v0", "VerticalCREnv-v0")


def _numpy2_windfield() -> None:
    from bluesky.traffic.windfield import Windfield

    original = Windfield.getdata

    def getdata(self, userlat, userlon, useralt=0.0):  # type: ignore[no-untyped-def]
        if type(userlat) in (list, np.ndarray):
            return original(self, userlat, userlon, useralt)
        vn, ve = original(self, [userlat], [userlon], useralt)
        return float(vn[0]), float(ve[0])

    Windfield.getdata = getdata


def actions(env_id: str, space, steps: int, seed: int) -> list[np.ndarray]:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(seed)
    out = [rng.uniform(space.low, space.high).astype(space.dtype) for _ in range(steps)]
    if env_id in SCALAR_ACTION_ENVS:
        out = [np.asarray(a[0]) for a in out]
    return out


def run(env_id: str, backend: str, steps: int, seed: int, warmup: int = 0) -> dict[str, np.ndarray]:
    start = time.perf_counter()
    if backend == "aamsim":
        import aamsim.compat.bluesky

        aamsim.compat.bluesky.install()
    import bluesky_gym
    import gymnasium as gym

    if backend == "bluesky":
        import bluesky  # noqa: F401 - the real one

        _numpy2_windfield()
    bluesky_gym.register_envs()
    env = gym.make(env_id)
    plan = actions(env_id, env.action_space, steps, seed)
    random.seed(seed)
    np.random.seed(seed)
    obs, _ = env.reset()
    keys = sorted(obs)
    rows: dict[str, list[np.ndarray]] = {k: [np.ravel(obs[k]).astype(float)] for k in keys}
    rewards, ends = [], []
    startup = time.perf_counter() - start
    t0 = time.perf_counter()
    for k, action in enumerate(plan):
        if k == warmup:
            t0 = time.perf_counter()
        obs, reward, terminated, truncated, _ = env.step(action)
        for k in keys:
            rows[k].append(np.ravel(obs[k]).astype(float))
        rewards.append(float(reward))
        ends.append((bool(terminated), bool(truncated)))
        if terminated or truncated:
            env.reset()  # the step's own observation is the one kept
    elapsed = time.perf_counter() - t0
    env.close()
    out = {f"obs/{k}": np.array(v) for k, v in rows.items()}
    out["reward"] = np.array(rewards)
    out["terminated"] = np.array([e[0] for e in ends])
    out["truncated"] = np.array([e[1] for e in ends])
    out["seconds"] = np.array(elapsed)  # the steps after the warm-up
    out["timed_steps"] = np.array(max(0, steps - warmup))
    out["startup_seconds"] = np.array(startup)
    return out


def main() -> None:
    env_id, backend, steps, seed, path = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
    warmup = int(sys.argv[6]) if len(sys.argv) > 6 else 0
    out = run(env_id, backend, steps, seed, warmup)
    np.savez(path, keys=json.dumps(sorted(out)), **out)


if __name__ == "__main__":
    main()
