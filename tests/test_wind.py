"""The wind field (WIND, GETWIND, DEL WIND) and its effect on the aircraft.

Expectations are computed by hand from BlueSky's definitions (module
docstring of :mod:`aamsim.traffic.wind`); ``tests/conformance/`` checks the
trajectories against BlueSky itself (wind2d.scn, wind3d.scn).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import errors_of
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.geo import qdrdist
from aamsim.traffic.wind import WindField, wind_from, wind_vector
from aamsim.units import FT, KTS


def make(*lines: str) -> Simulation:
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    for line in lines:
        assert sim.stack(line), errors_of(sim)
    return sim


def test_wind_vector_points_where_the_wind_blows_to():
    vn, ve = wind_vector(270.0, 10.0)  # from the west: blows east
    assert vn == pytest.approx(0.0, abs=1e-12) and ve == pytest.approx(10.0)
    vn, ve = wind_vector(0.0, 4.0)  # from the north: blows south
    assert vn == pytest.approx(-4.0) and ve == pytest.approx(0.0, abs=1e-12)
    assert wind_from(10.0, 0.0) == pytest.approx((180.0, 10.0))  # blowing north: from the south


def test_one_point_is_the_wind_everywhere_at_every_altitude():
    field = WindField()
    field.add_point(52.0, 4.0, 270.0, 20.0)
    assert field.dim == 1
    for lat, lon, alt in ((52.0, 4.0, 0.0), (-30.0, 100.0, 9000.0)):
        vn, ve = field.get(lat, lon, alt)
        assert vn == pytest.approx(0.0, abs=1e-12) and ve == pytest.approx(20.0)


def test_inverse_distance_squared_between_points():
    field = WindField()
    field.add_point(0.0, 0.0, 270.0, 10.0)  # east 10 m/s
    field.add_point(0.0, 2.0, 270.0, 30.0)  # east 30 m/s
    assert field.dim == 2
    # Midway: equal weights.
    assert field.get(0.0, 1.0)[1] == pytest.approx(20.0)
    # At 0.5 deg from the first and 1.5 deg from the second: weights 4 and 4/9.
    w1, w2 = 1 / 0.25, 1 / 2.25
    assert field.get(0.0, 0.5)[1] == pytest.approx((10 * w1 + 30 * w2) / (w1 + w2))
    # Exactly on a point: that point's wind (the 1e-20 deg^2 guard).
    assert field.get(0.0, 2.0)[1] == pytest.approx(30.0)
    # Longitude differences count times the cosine of the mean latitude: at 60N a
    # degree of longitude weighs like half a degree of latitude.
    field = WindField()
    field.add_point(60.0, 0.0, 270.0, 10.0)
    field.add_point(61.0, 2.0, 270.0, 30.0)
    lat = 60.5
    dx1 = math.cos(math.radians(60.25)) * 1.0
    dx2 = math.cos(math.radians(60.75)) * -1.0
    w1, w2 = 1 / (dx1**2 + 0.25), 1 / (dx2**2 + 0.25)
    assert field.get(lat, 1.0)[1] == pytest.approx((10 * w1 + 30 * w2) / (w1 + w2), rel=1e-12)


def test_profile_linear_between_altitudes_constant_beyond():
    field = WindField()
    field.add_profile(52.0, 4.0, [1000 * FT, 3000 * FT], [270.0, 270.0], [10.0, 30.0])
    assert field.dim == 3
    east = lambda alt_ft: field.get(52.0, 4.0, alt_ft * FT)[1]  # noqa: E731
    assert east(0) == pytest.approx(10.0)  # below the lowest: the lowest
    assert east(2000) == pytest.approx(20.0)
    assert east(2050) == pytest.approx(20.5)  # between table rows 2000 and 2100 ft
    assert east(9000) == pytest.approx(30.0)  # above the highest: the highest
    assert east(60000) == pytest.approx(30.0)  # above the table's 45,000 ft
    # A point without a profile holds at every altitude next to one with a profile.
    field.add_point(52.0, 6.0, 270.0, 50.0)
    assert field.get(52.0, 5.0, 2000 * FT)[1] == pytest.approx(35.0)
    assert field.get(52.0, 5.0, 9000 * FT)[1] == pytest.approx(40.0)


def test_profile_altitudes_in_any_order():
    a, b = WindField(), WindField()
    a.add_profile(0.0, 0.0, [0.0, 1000.0], [90.0, 180.0], [5.0, 15.0])
    b.add_profile(0.0, 0.0, [1000.0, 0.0], [180.0, 90.0], [15.0, 5.0])
    assert a.get(0.0, 0.0, 400.0) == b.get(0.0, 0.0, 400.0)


def test_the_wind_api_is_the_wind_command():
    # From the west (270 deg) at 10 m/s: the air moves east, 10 m/s east and 0 north, at every altitude.
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    assert sim.wind_at(52.0, 4.0, 0.0) == (0.0, 0.0)
    sim.add_wind_point(52.0, 4.0, 270.0, 10.0)
    vn, ve = sim.wind_at(52.0, 4.0, 500.0)
    assert vn == pytest.approx(0.0, abs=1e-12) and ve == pytest.approx(10.0)
    cmd = make("WIND 52,4,,270,10")  # kt, the command's unit
    assert cmd.wind_at(52.0, 4.0, 500.0) == pytest.approx((0.0, 10 * KTS), abs=1e-12)
    # A profile: 100 m from the south at 4 m/s, 300 m from the south at 8 m/s; halfway between, 6 m/s north.
    sim.clear_wind()
    sim.add_wind_profile(52.0, 4.0, np.array([100.0, 300.0]), np.array([180.0, 180.0]), np.array([4.0, 8.0]))
    vn, ve = sim.wind_at(52.0, 4.0, 200.0)
    assert vn == pytest.approx(6.0) and ve == pytest.approx(0.0, abs=1e-12)
    sim.clear_wind()
    assert sim.wind_at(52.0, 4.0, 200.0) == (0.0, 0.0)


def test_wind_and_getwind_commands():
    sim = make("WIND 52,4,,300,100")  # empty altitude: no profile
    assert sim._wind.dim == 1
    assert sim.stack("GETWIND 52 4")
    assert sim.reporter.messages[-1].text == "WIND AT 52.00000, 4.00000: 300/100"
    sim.stack("WIND 52,4,0,270,50,10000,300,400")  # BlueSky's test_wind.scn
    assert sim._wind.dim == 3
    sim.stack("GETWIND 52 4 FL050")
    # Equal weights of the two points at 5000 ft: 300/100 and the profile's midpoint.
    p = WindField()
    p.add_profile(52, 4, [0.0, 10000 * FT], [270.0, 300.0], [50 * KTS, 400 * KTS])
    vn, ve = p.get(52, 4, 5000 * FT)
    vn2, ve2 = wind_vector(300.0, 100 * KTS)
    direction, speed = wind_from((vn + vn2) / 2, (ve + ve2) / 2)
    assert sim.reporter.messages[-1].text == f"WIND AT 52.00000, 4.00000: {round(direction):03d}/{round(speed / KTS)}"
    assert sim.stack("DEL WIND") and sim._wind.dim == 0 and len(sim._wind) == 0


@pytest.mark.parametrize("line, fragment", [
    ("WIND 52 4 270", "not recognised"),
    ("WIND 52 4 0 270 10 500 280", "not recognised"),
    ("WIND 52,4,,270,,", "speed missing"),
    ("WIND 52 4 abc 10", "direction"),
    ("WIND 52 4 0 270 10 XX 280 20", "altitude"),
    ("WIND NOWHERE 270 10", "position"),
])
def test_wind_errors_name_the_field(line, fragment):
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    assert not sim.stack(line)
    assert fragment in errors_of(sim)[-1]
    assert sim._wind.dim == 0


def test_del_wind_keeps_an_aircraft_called_wind_first():
    sim = make("WIND 0 0 90 10", "CRE WIND EC35 0 0 0 1000 100", "DEL WIND")
    assert "WIND" not in sim.view and sim._wind.dim == 1


@settings(max_examples=40, deadline=None)
@given(direction=st.integers(0, 359), speed_kt=st.integers(1, 200), lat=st.floats(-80, 80), lon=st.floats(-179, 179))
def test_getwind_returns_what_wind_defined(direction, speed_kt, lat, lon):
    sim = make(f"WIND {lat:.6f} {lon:.6f} {direction} {speed_kt}")
    sim.stack(f"GETWIND {lat:.6f} {lon:.6f}")
    assert sim.reporter.messages[-1].text.endswith(f": {direction:03d}/{speed_kt}")


def test_heading_hold_drifts_with_the_wind():
    # From 270 at 20 kt (blowing east), flying north at 100 kt TAS, HDG selected:
    # track atan(20/100) east of north, ground speed sqrt(100^2 + 20^2).
    sim = make("WIND 40 -74 270 20", "CRE A EC35 40 -74 0 1500 100", "HDG A 0")
    sim.run_until(120)
    v = sim.view
    tas = float(v.tas[0])
    assert v.hdg[0] == pytest.approx(0.0, abs=1e-9)
    assert v.trk[0] == pytest.approx(math.degrees(math.atan2(20 * KTS, tas)), abs=1e-9)
    assert v.gs[0] == pytest.approx(math.hypot(tas, 20 * KTS), rel=1e-12)
    # Displacement: TAS north plus the wind east, 120 s.
    qdr, dist = qdrdist(40, -74, float(v.lat[0]), float(v.lon[0]))
    assert dist == pytest.approx(120 * math.hypot(tas, 20 * KTS), rel=3e-3)  # flat-earth step vs WGS-84
    assert qdr == pytest.approx(math.degrees(math.atan2(20 * KTS, tas)), abs=0.05)


def test_route_flown_with_wind_correction():
    # The same wind; a waypoint to the north: the heading crabs into the wind so that
    # the track is the bearing to the waypoint: sin(crab) = 20 sin(track - 90) / TAS.
    sim = make("WIND 40 -74 270 20", "CRE A EC35 40 -74 0 1500 100", "ADDWPT A 40.5 -74")
    sim.run_until(120)
    v = sim.view
    tas = float(v.tas[0])
    trk = float(v.trk[0])
    qdr, _ = qdrdist(float(v.lat[0]), float(v.lon[0]), 40.5, -74.0)
    assert (trk - qdr + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-3)  # flying the bearing
    crab = math.degrees(math.asin(20 * KTS * math.sin(math.radians(trk - 90.0)) / tas))
    assert (v.hdg[0] - (trk + crab) + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-3)
    assert crab == pytest.approx(-math.degrees(math.asin(20 * KTS / tas)), abs=0.05)
    assert v.gs[0] == pytest.approx(tas * math.cos(math.radians(crab)) + 20 * KTS * math.sin(math.radians(trk)),
                                    rel=1e-5)


def test_no_wind_at_or_below_50_ft_but_the_heading_still_crabs():
    sim = make("WIND 40 -74 270 20", "CRE G EC35 40 -74 0 0 30", "CRE H EC35 40.1 -74 0 49 30")
    sim.run_until(10)
    v = sim.view
    # Ground speed is TAS, track is heading: the wind does not move them.
    assert list(v.gs) == list(v.tas) and list(v.trk) == list(v.hdg)
    # BlueSky's autopilot corrects for the wind at any altitude, so the heading turns
    # into it (left of the 0 deg track) and the aircraft creeps west.
    assert 180.0 < v.hdg[0] < 360.0 and v.lon[0] < -74.0


def test_wind_after_del_wind_and_reset():
    calm = make("CRE A EC35 40 -74 90 1500 100")
    windy = make("WIND 40 -74 0 30", "CRE A EC35 40 -74 90 1500 100", "DEL WIND")
    calm.run_until(60)
    windy.run_until(60)
    # The track held is the one flown at creation in the wind; without wind now, the
    # heading turns onto it and the aircraft flies it at its TAS.
    assert windy.view.gs[0] == pytest.approx(windy.view.tas[0])
    assert windy.view.trk[0] == pytest.approx(90.0 + math.degrees(math.atan2(30 * KTS, calm.view.tas[0])), abs=1e-6)
    windy.stack("WIND 0 0 0 30")
    windy.reset()
    assert windy._wind.dim == 0
