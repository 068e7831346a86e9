"""The corridor separation-assurance use case: observations, rewards, actions (hand-computed)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aamsim import Simulation
from aamsim.traffic import fields as f
from aamsim.units import KTS
from rlbridge.usecases import make_usecase
from rlbridge.usecases.corridor import ACCELERATE, DECELERATE, HOLD

R = 6371000.0


def metres(deg: float) -> float:
    return R * math.radians(deg)


@pytest.fixture
def scene():
    """Ownship O at (0, 0) heading east with a two-waypoint route; A 556 m north and 50 m
    higher; B 2224 m west. All on the equator, so the flat offsets are R * angle."""
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.stack("CRE O EC35 0 0 90 984.25 100")  # 300 m
    sim.stack("ADDWPT O 0 0.01; ADDWPT O 0 0.02; ADDWPT O 0.01 0.03")
    sim.stack("CRE A EC35 0.005 0 180 1148.29 80")  # 350 m
    sim.stack("CRE B EC35 0 -0.02 90 984.25 120")
    F = sim._traffic.F
    for acid, ax, gs, alt in (("O", 1.0, 50.0, 300.0), ("A", -2.0, 40.0, 350.0), ("B", 0.0, 60.0, 300.0)):
        i = sim.view.slot(acid)
        F[f.AX, i] = ax
        F[f.GS, i] = gs
        F[f.ALT, i] = F[f.SELALT, i] = alt
    return sim


def test_flat_observation_hand_computed(scene):
    uc = make_usecase("corridor_sa", n_intruders=3)
    obs = uc.observe(scene, ["O"]).flat[0]
    assert obs.shape == (9 + 3 * 11,)
    # Ownship: hdg/360, alt/1000, a/3.5, v/100, d_dest/5000, then waypoints (x, y)/5000.
    # LNAV flies to the first waypoint (0, 0.01): next two are (0, 0.01) and (0, 0.02);
    # the destination (last waypoint) is (0.01, 0.03).
    d_dest = math.hypot(metres(0.01), metres(0.03) * math.cos(math.radians(0.005)))
    expected_own = [90 / 360, 0.3 / 1, 1.0 / 3.5, 50 / 100, d_dest / 5000,
                    metres(0.01) / 5000, 0.0, metres(0.02) / 5000, 0.0]
    np.testing.assert_allclose(obs[:9], expected_own, rtol=1e-5, atol=1e-6)
    # Closest intruder first: A (556 m north, +50 m), then B (2224 m west).
    dy_a = metres(0.005)
    d_a = math.hypot(dy_a, 50.0)
    a = obs[9:20]
    # A has no route: its "waypoints" are its own position; d_dest 0.
    np.testing.assert_allclose(a, [0.0, dy_a / 5000, 50 / 100, -2.0 / 3.5, 40 / 100, 0.0, d_a / 5000,
                                   0.0, dy_a / 5000, 0.0, dy_a / 5000], rtol=1e-5, atol=1e-6)
    b = obs[20:31]
    dx_b = -metres(0.02)
    np.testing.assert_allclose(b, [dx_b / 5000, 0.0, 0.0, 0.0, 60 / 100, 0.0, abs(dx_b) / 5000,
                                   dx_b / 5000, 0.0, dx_b / 5000, 0.0], rtol=1e-5, atol=1e-6)
    # Padding: the third intruder slot is all zeros.
    assert not obs[31:].any()


def test_dict_observation_and_mask(scene):
    uc = make_usecase("corridor_sa", n_intruders=4, obs_format="dict")
    obs = uc.observe(scene, ["O", "B"])
    assert obs.parts["ownship"].shape == (2, 9)
    assert obs.parts["intruders"].shape == (2, 4, 11)
    np.testing.assert_array_equal(obs.parts["mask"], [[1, 1, 0, 0], [1, 1, 0, 0]])
    assert uc.observation_space().contains(obs.row(0))
    # B's closest is O (2224 m), then A.
    assert obs.parts["intruders"][1, 0, 6] == pytest.approx(metres(0.02) / 5000, rel=1e-5)


def test_intruder_range_and_order(scene):
    uc = make_usecase("corridor_sa", n_intruders=30, intruder_range_m=1000.0, d_max_m=500.0)
    obs = uc.observe(scene, ["O"]).flat[0]
    # Only A is within 1000 m: one intruder block, the rest zero.
    assert obs[9 + 1] == pytest.approx(metres(0.005) / 5000, rel=1e-5)
    assert not obs[20:].any()


def test_reward_branches():
    sim = Simulation()  # the rewards read the NMAC distance of its separation standard: 150 m by default
    uc = make_usecase("corridor_sa")
    agents = ["N", "M", "F", "A"]
    closest = np.array([100.0, 1000.0, 5000.0, 1000.0])
    actions = {"N": HOLD, "M": HOLD, "F": HOLD, "A": ACCELERATE}
    r = uc.rewards(sim, agents, actions, closest, {})
    # d < 150: -1; 150 <= d < 3000: -1 + 0.0003 d; else 0; minus Omega = 0.001; -psi = 0.001 if not hold.
    np.testing.assert_allclose(r, [-1.001, -1 + 0.3 - 0.001, -0.001, -1 + 0.3 - 0.001 - 0.001])
    # An NMAC during the interval counts even if the aircraft are apart at the decision.
    r2 = uc.rewards(sim, ["M"], {}, np.array([1000.0]), {"M": 80.0})
    assert r2[0] == pytest.approx(-1.001)
    r3 = make_usecase("corridor_sa", reward_interval_nmac=False).rewards(sim, ["M"], {}, np.array([1000.0]),
                                                                         {"M": 80.0})
    assert r3[0] == pytest.approx(-0.701)
    # Another standard, another NMAC branch: with a 50 m NMAC volume, 100 m apart is not an NMAC.
    sim.stack("SEPVOLUME NMAC 50 50")
    r4 = uc.rewards(sim, ["N"], {"N": HOLD}, np.array([100.0]), {})
    assert r4[0] == pytest.approx(-1 + 0.03 - 0.001)


def test_action_effects_on_target_speed(scene):
    uc = make_usecase("corridor_sa")
    t = scene._traffic
    cas_b = float(t.cas[t.index("B")])
    uc.apply_actions(scene, {"O": DECELERATE, "A": ACCELERATE, "B": HOLD})
    assert t.F[f.SELSPD, t.index("O")] == 0.0
    assert t.F[f.SELSPD, t.index("A")] == pytest.approx(150 * KTS)
    assert t.F[f.SELSPD, t.index("B")] == pytest.approx(cas_b)
    assert [r.advisories for r in t.flights] == [1, 1, 0]  # hold is not an alert
    scene.run_until(60.0)
    assert t.tas[t.index("O")] == 0.0  # hovering
    assert t.tas[t.index("A")] == pytest.approx(71.95)  # EC135 envelope caps 150 kt
    with pytest.raises(ValueError):
        uc.apply_actions(scene, {"O": 7})


def test_unknown_parameters_rejected():
    with pytest.raises(ValueError, match="unknown use-case parameter"):
        make_usecase("corridor_sa", n_intruder=3)
    with pytest.raises(KeyError):
        make_usecase("no_such_usecase")


def test_track_frame_and_relative_velocity_options(scene):
    # O flies east (trk 90): in its track frame, A (556 m north) is 556 m to the LEFT (negative
    # "right of track") and 0 ahead; B (2224 m west) is 2224 m behind.
    uc = make_usecase("corridor_sa", n_intruders=2, frame="track", relative_velocity=True, obs_format="dict")
    assert uc.intruder_dim == 13
    obs = uc.observe(scene, ["O"]).parts
    dy_a = metres(0.005)
    a, b = obs["intruders"][0]
    np.testing.assert_allclose(a[:2], [0.0, -dy_a / 5000], atol=1e-6)
    np.testing.assert_allclose(b[:2], [-metres(0.02) / 5000, 0.0], atol=1e-6)
    # Waypoints straight ahead along the track.
    np.testing.assert_allclose(obs["ownship"][0, 5:9], [metres(0.01) / 5000, 0.0, metres(0.02) / 5000, 0.0],
                               atol=1e-6)
    # A flies south at 40 m/s: relative to O (east at 50 m/s) that is 50 m/s back and 40 m/s to the right.
    np.testing.assert_allclose(a[11:13], [-50 / 100, 40 / 100], atol=1e-6)
    # B flies east at 60 m/s: 10 m/s faster along the track.
    np.testing.assert_allclose(b[11:13], [10 / 100, 0.0], atol=1e-6)
    with pytest.raises(ValueError):
        make_usecase("corridor_sa", frame="polar")


@pytest.mark.parametrize("lanes", [(), (500.0, 1200.0, 1900.0)])
def test_altitude_noise_added_or_redrawn_around_the_lane(lanes):
    """A flight converted at lane 1,200 ft + 90 ft: added noise can reach 1,390 ft; noise
    re-drawn around the lane stays within 1,200 +- 100 ft (the paper's bound)."""
    from aamsim.units import FT

    uc = make_usecase("corridor_sa", alt_noise_ft=100.0, alt_noise_lanes_ft=list(lanes))
    offsets = []
    for seed in range(200):
        sim = Simulation(seed=seed, use_bluesky_navdata=False)
        uc.attach(sim)
        sim.stack("CRE X EC35 40.7 -74.0 0 1290 0")
        i = sim.view.slot("X")
        alt_ft = sim._traffic.F[f.ALT, i] / FT
        assert sim._traffic.F[f.SELALT, i] == sim._traffic.F[f.ALT, i]
        offsets.append(alt_ft - (1200.0 if lanes else 1290.0))
    assert max(abs(o) for o in offsets) <= 100.0 + 1e-6
    assert min(offsets) < -80 and max(offsets) > 80  # the whole band is used
    again = Simulation(seed=7, use_bluesky_navdata=False)
    uc.attach(again)
    again.stack("CRE X EC35 40.7 -74.0 0 1290 0")
    assert again._traffic.F[f.ALT, 0] / FT == pytest.approx(offsets[7] + (1200.0 if lanes else 1290.0))
    # Off the lanes (another scenario's 3,000 ft): the noise is added, whatever the lanes.
    off_lane = Simulation(seed=7, use_bluesky_navdata=False)
    uc.attach(off_lane)
    off_lane.stack("CRE Y EC35 40.7 -74.0 0 3000 0")
    assert off_lane._traffic.F[f.ALT, 0] / FT == pytest.approx(3000.0 + offsets[7])  # the same draw, added


def test_variant_v1_charges_hovering_and_the_paper_does_not(scene):
    """v1 (docs/usecase-corridor.md): -hover_cost per decision under 5 kt ground speed; the paper: free."""
    paper = make_usecase("corridor_sa")
    v1 = make_usecase("corridor_sa", variant="v1", hover_cost=0.05)
    paper.apply_actions(scene, {"O": DECELERATE, "A": ACCELERATE})
    scene.run_until(60.0)
    agents = ["O", "A"]
    closest = np.array([5000.0, 5000.0])  # nobody near: only Omega (and the hover cost)
    np.testing.assert_allclose(v1.hovering(scene, agents), [1.0, 0.0])
    np.testing.assert_allclose(paper.rewards(scene, agents, {}, closest, {}), [-0.001, -0.001])
    np.testing.assert_allclose(v1.rewards(scene, agents, {}, closest, {}), [-0.051, -0.001])


def test_variant_names_its_reward():
    with pytest.raises(ValueError, match="variant='v1'"):
        make_usecase("corridor_sa", hover_cost=0.05)  # the paper's name with another reward
    with pytest.raises(ValueError, match="positive hover_cost"):
        make_usecase("corridor_sa", variant="v1")
    with pytest.raises(ValueError, match="variant must be"):
        make_usecase("corridor_sa", variant="v2")
