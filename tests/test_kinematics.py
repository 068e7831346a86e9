"""Kinematics and autopilot against hand-computed values."""

from __future__ import annotations

import math

import pytest

from aamsim import Simulation
from aamsim.aero import cas2tas, tas2cas
from aamsim.geo import qdrdist
from aamsim.traffic import fields as f
from aamsim.units import FPM, FT, KTS, R_EARTH


def make(*lines, dt=0.05):
    sim = Simulation(seed=1, dt=dt, use_bluesky_navdata=False)
    sim.load_text("\n".join(f"00:00:00.00>{ln}" for ln in lines))
    return sim


def test_straight_flight_100_kts_east_600_s():
    # 100 kts at sea level (CAS = TAS) due east on the equator for 600 s:
    # 100 * 0.514444 * 600 = 30866.64 m along the 6371 km sphere.
    sim = make("CRE A EC35 0 0 90 0 100")
    sim.run_until(600.0)
    assert sim.view.tas[0] == pytest.approx(51.4444, rel=1e-9)
    assert sim._traffic.F[f.DISTFLOWN, 0] == pytest.approx(30866.64, rel=1e-9)
    assert math.radians(sim.view.lon[0]) * R_EARTH == pytest.approx(30866.64, rel=1e-9)
    assert sim.view.lat[0] == pytest.approx(0.0, abs=1e-12)


def test_isa_speed_conversions():
    # At sea level CAS equals TAS (to the 1e-10 the ISA constants allow);
    # at 10 000 ft a 250 kt CAS is 288.7 kt TAS (E6B: 288.6).
    assert cas2tas(100.0, 0.0) == pytest.approx(100.0, rel=1e-9)
    assert cas2tas(250 * KTS, 10000 * FT) / KTS == pytest.approx(288.7, abs=0.2)
    assert tas2cas(cas2tas(77.0, 1234.0), 1234.0) == pytest.approx(77.0, rel=1e-12)


def test_speed_ramps_at_axmax_after_first_performance_refresh():
    # Created at t=0: the refresh at t=0 gives the EC135 its 3.5 m/s^2.
    sim = make("CRE A EC35 0 0 90 0 0", "SPD A 100")
    sim.run_until(2.0)
    assert sim.view.tas[0] == pytest.approx(7.0)
    # Created between refreshes: 2 m/s^2 (BlueSky's default) until the next one.
    sim2 = make("CRE A EC35 0 0 90 0 0")
    sim2.schedule(0.5, "CRE B EC35 0 1 90 0 0; SPD B 100")
    sim2.run_until(1.5)
    i = sim2.view.slot("B")
    assert sim2.view.tas[i] == pytest.approx(2.0 * 0.5 + 3.5 * 0.5)


def test_envelope_caps_ec135_tas():
    sim = make("CRE A EC35 40 -74 90 1500 200")
    sim.run_until(30.0)
    assert sim.view.tas[0] == pytest.approx(71.95)


def test_turn_rate_from_bank_angle():
    # 100 kts at sea level, 25 deg bank: rate = g tan(25)/V = 5.092 deg/s.
    sim = make("CRE A EC35 0 0 0 0 100", "HDG A 90")
    sim.run_until(1.0)
    expected = math.degrees(9.80665 * math.tan(math.radians(25)) / (100 * KTS))
    assert sim.view.hdg[0] == pytest.approx(expected, rel=1e-9)


def test_climb_with_vertical_speed_ramp():
    # The default 1500 fpm (7.62 m/s) is reached through BlueSky's ramp: +300 fpm/s
    # (0.0762 m/s per 0.05 s step) until the gap to the target is no more than
    # 1.524 m/s, then a jump to the target. That is 80 ramp steps (V/S = 0.0762 k)
    # and, within 10 s, 120 steps at 7.62 m/s:
    # 0.05 * (0.0762 * (1 + ... + 80) + 120 * 7.62) = 12.3444 + 45.72 = 58.0644 m.
    sim = make("CRE A EC35 0 0 0 1000 100", "ALT A 5000")
    sim.run_until(10.0)
    assert sim.view.vs[0] == pytest.approx(1500 * FPM)
    assert sim.view.alt[0] - 1000 * FT == pytest.approx(58.0644, abs=1e-6)
    sim.run_until(400.0)
    assert sim.view.alt[0] == pytest.approx(5000 * FT)
    assert sim.view.vs[0] == 0.0


def test_explicit_vertical_speed_and_ec135_limit():
    sim = make("CRE A EC35 0 0 0 1000 100", "ALT A 9000 3000")
    sim.run_until(60.0)
    # 3000 fpm is above the EC135's 1500 fpm (7.62 m/s) limit.
    assert sim.view.vs[0] == pytest.approx(7.62)


def test_route_following_passes_waypoints_and_ends_on_last_track():
    sim = make("CRE A EC35 40.70 -74.00 0 1500 120", "ADDWPT A 40.72 -74.00", "ADDWPT A 40.72 -73.97")
    sim.run_until(1.0)
    assert sim._traffic.B[f.B_SWLNAV, 0]
    sim.run_until(400.0)
    # Past the last waypoint: LNAV off, flying east along the last leg.
    assert not sim._traffic.B[f.B_SWLNAV, 0]
    assert sim.view.hdg[0] == pytest.approx(90.0, abs=0.5)
    assert sim.view.lat[0] == pytest.approx(40.72, abs=0.002)


def test_flyby_cuts_the_corner_and_flyover_does_not():
    def closest_approach(mode):
        sim = make("CRE A EC35 40.70 -74.00 0 1500 120", f"ADDWPT A {mode}",
                   "ADDWPT A 40.72 -74.00", "ADDWPT A 40.72 -73.95")
        best = 1e9
        while sim.simt < 300:
            sim.run_until(sim.simt + 0.05)
            best = min(best, qdrdist(sim.view.lat[0], sim.view.lon[0], 40.72, -74.00)[1])
        return best
    flyby, flyover = closest_approach("FLYBY"), closest_approach("FLYOVER")
    # Fly-by anticipates by R tan(45 deg) = V^2/(g tan 25) ~ 800 m; passes ~330 m inside the corner.
    assert 150 < flyby < 600
    assert flyover < 10


def test_dest_descends_with_vnav_at_three_degree_gradient():
    # 1500 ft at 3000 ft per 10 NM needs 9.26 km: the descent starts when the
    # destination (11.1 km north) is that close.
    sim = make("CRE A EC35 40.70 -74.00 0 1500 100", "DEST A 40.80 -74.00")
    sim.run_until(20.0)
    assert sim.view.alt[0] == pytest.approx(1500 * FT)
    sim.run_until(100.0)
    # The V/S is planned when the leg is activated, from the ground speed then.
    gs0 = float(cas2tas(100 * KTS, 1500 * FT))
    assert sim.view.vs[0] == pytest.approx(-gs0 * 3000 * FT / (10 * 1852), rel=1e-9)


def test_speed_conversions_of_floats_and_arrays_agree_bit_for_bit():
    # Floats go through the compiled scalar functions, arrays through ufuncs built at their first use.
    import numpy as np

    from aamsim import aero

    rng = np.random.default_rng(3)
    cas, alt = rng.uniform(-80.0, 300.0, 500), rng.uniform(-300.0, 15000.0, 500)
    tas_array = aero.cas2tas(cas, alt)
    back_array = aero.tas2cas(tas_array, alt)
    assert isinstance(aero.cas2tas(50.0, 100), float) and isinstance(aero.tas2cas(np.float64(50.0), 100.0), float)
    assert [aero.cas2tas(c, h) for c, h in zip(cas, alt)] == tas_array.tolist()
    assert [aero.tas2cas(t, h) for t, h in zip(tas_array, alt)] == back_array.tolist()
    assert np.allclose(back_array, cas, rtol=1e-12, atol=1e-9)  # the pair inverts
    assert abs(aero.cas2tas([50.0], [0.0])[0] - 50.0) < 1e-8  # at sea level CAS = TAS (ISA)
