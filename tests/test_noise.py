"""NOISE: BlueSky's turbulence, seeded by the simulation."""

from __future__ import annotations

import math

import numpy as np

from aamsim import Simulation


def _run(seed: int, noise: bool = True, n: int = 200, until: float = 100.0) -> Simulation:
    sim = Simulation(seed=seed, use_bluesky_navdata=False)
    lines = [f"0:0:0>CRE A{k} EC35 40 {-74 + k * 0.01:.2f} 0 1500 100" for k in range(n)]
    if noise:
        lines.insert(0, "0:0:0>NOISE ON")
    sim.load_text("\n".join(lines) + "\n")
    sim.run_until(until)
    return sim


def test_same_seed_same_noise_other_seed_other_noise():
    a, b, c = _run(7, n=5, until=20), _run(7, n=5, until=20), _run(8, n=5, until=20)
    assert np.array_equal(a.view.lon, b.view.lon) and np.array_equal(a.view.lat, b.view.lat)
    assert not np.array_equal(a.view.lon, c.view.lon)


def test_cross_track_random_walk_has_bluesky_spread():
    # Flying north, the cross-track offset is east: a random walk of 0.1 m/sqrt(s), so after
    # 100 s its standard deviation over 200 aircraft is 1.0 m (within 15 % with 200 samples).
    noisy, calm = _run(3), _run(3, noise=False)
    coslat = math.cos(math.radians(40.0))
    east = np.radians(noisy.view.lon - calm.view.lon) * 6371000.0 * coslat
    north = np.radians(noisy.view.lat - calm.view.lat) * 6371000.0
    assert 0.85 < float(np.std(east)) < 1.15
    assert abs(float(np.mean(east))) < 0.25
    # Along track: BlueSky's standard deviation 0 (clamped to 1e-6 m/sqrt(s)).
    assert float(np.max(np.abs(north))) < 1e-3


def test_noise_off_and_query():
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    sim.load_text("0:0:0>NOISE ON\n0:0:1>NOISE OFF\n0:0:1>NOISE\n")
    sim.run_until(2)
    assert "turbulence" not in sim.hooks.post_step.names()
    assert not sim.reporter.errors()
