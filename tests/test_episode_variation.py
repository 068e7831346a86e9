"""Episodes vary with the reset seed by default, in every use case; fixed traffic stays available (issue 28).

Before: ``gym.make("aamgym/CorridorSA-v0")`` gave identical observations for ``reset(seed=1)`` and
``reset(seed=2)``, the ego was always UAM0940 and SB3's ``evaluate_policy`` reported a std of 0.0.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import rlbridge  # noqa: F401  (registers the environments)
from aamsim import Simulation
from rlbridge.usecases.registry import BUILTIN_USECASES, env_id
from rlbridge.usecases.variation import redraw_altitude

SCENARIO = "nyc_train_100"
STEPS = 12
# A planner's observations are its requests and the planned intents (the plan, not the flights): the
# flights' drawn altitudes show in its rewards (NMAC/LoWC penalties) once enough of them fly.
PLANNER_STEPS = 100


def _episode(eid: str, seed: int, **kwargs) -> tuple[str, list[np.ndarray], list[float]]:
    """The ego and what it sees and earns over a fixed action sequence (action 0, a valid action everywhere)."""
    env = gym.make(eid, scenario=SCENARIO, **kwargs)
    try:
        obs, _ = env.reset(seed=seed)
        seen, rewards = [gym.spaces.flatten(env.observation_space, obs)], []
        steps = PLANNER_STEPS if env.unwrapped.ego in getattr(env.unwrapped._multi._usecase, "standing_agents", ()) \
            else STEPS
        for _ in range(steps):
            obs, reward, terminated, truncated, _ = env.step(0)
            seen.append(gym.spaces.flatten(env.observation_space, obs))
            rewards.append(float(reward))
            if terminated or truncated:
                break
        return env.unwrapped.ego, seen, rewards
    finally:
        env.close()


def _same(a: tuple, b: tuple) -> bool:
    return a[0] == b[0] and len(a[1]) == len(b[1]) and all(np.array_equal(x, y) for x, y in zip(a[1], b[1])) \
        and a[2] == b[2]


@pytest.mark.parametrize("usecase", sorted(BUILTIN_USECASES))
def test_another_seed_gives_another_episode_and_the_same_seed_the_same(usecase):
    eid = env_id(usecase)
    assert eid.endswith("-v1")
    one, again, other = _episode(eid, 1), _episode(eid, 1), _episode(eid, 2)
    assert _same(one, again)
    assert not _same(one, other)


def test_the_use_case_draws_vary_the_episode_even_with_a_fixed_ego():
    """corridor_sa's altitude noise changes who meets whom. (A planner is always the same ego, so the
    test above covers the planners; a reach_destination aircraft's task does not depend on the other
    traffic, and its drawn cruise speed is still being reached when it first decides: with a fixed
    ego its episode does not vary, docs/usecases.md "Episode variation".)"""
    eid = env_id("corridor_sa")
    assert not _same(_episode(eid, 1, ego="UAM0987"), _episode(eid, 2, ego="UAM0987"))


@pytest.mark.parametrize("usecase", sorted(BUILTIN_USECASES))
def test_v0_keeps_the_fixed_traffic_of_results_made_before(usecase):
    eid = env_id(usecase, 0)
    assert eid.endswith("-v0")
    one, other = _episode(eid, 1), _episode(eid, 2)
    env = gym.make(eid, scenario=SCENARIO)
    assert one[0] == env.unwrapped._candidates[0]  # the first agent the scenario names, every time
    env.close()
    assert _same(one, other)


def test_altitude_noise_redraws_about_the_lane_or_adds_off_lanes():
    """Hand-made: an aircraft 40 ft above the 1,200 ft lane gets a fresh offset about the lane; one at
    3,000 ft (no lane within 100 ft) gets the noise added to its altitude."""
    ft = 0.3048
    lanes = np.array([500.0, 1200.0, 1900.0]) * ft
    sim = Simulation(seed=7)
    sim.stack("CRE A EC35 40.7 -74.0 0 1240 0; CRE B EC35 40.8 -74.0 0 3000 0")
    draws = np.random.default_rng(7).uniform(-100.0, 100.0, 2)  # what the simulation's generator draws
    sim.reseed(7)
    for slot in range(2):
        redraw_altitude(sim, slot, 100.0, lanes)
    assert sim.view.alt[0] == pytest.approx((1200.0 + draws[0]) * ft, abs=1e-6)
    assert sim.view.alt[1] == pytest.approx((3000.0 + draws[1]) * ft, abs=1e-6)


def test_reach_destination_aircraft_fly_their_drawn_cruise_speed_until_their_first_decision():
    from aamsim.units import KTS
    from rlbridge.core import EpisodeCore

    speeds = {}
    for seed in (1, 2):
        core = EpisodeCore(SCENARIO, "reach_destination", {}, time_limit_s=None, dt=0.05)
        result = core.reset(seed)
        slots = core.sim.slots(result.agents)
        speeds[seed] = core.sim.view.selspd[slots] / KTS
        core.close()
    assert len(speeds[1]) and np.all((speeds[1] >= 87.0) & (speeds[1] <= 150.0))
    assert not np.allclose(speeds[1], speeds[2])
