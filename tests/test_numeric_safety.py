"""Physics stays finite (issue 19 item 6, issue 17 item 5): absurd speeds, poles, the antimeridian, altitudes,
zero-length legs, and a guard that names the aircraft and command when a state goes non-finite anyway."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import errors_of

from aamsim import Simulation
from aamsim.traffic import fields as f
from aamsim.units import KTS, NM, R_EARTH


def make() -> Simulation:
    return Simulation(seed=1, use_bluesky_navdata=False)


def state(sim: Simulation, acid: str) -> tuple[float, float, float, float]:
    t = sim._traffic
    i = t.index(acid)
    return float(t.lat[i]), float(t.lon[i]), float(t.alt[i]), float(t.tas[i])


@pytest.mark.parametrize("speed", ["1e300", "1e6"])
def test_an_absurd_creation_speed_is_limited_to_the_type_with_a_warning(speed: str) -> None:
    sim = make()
    sim.stack(f"CRE A EC35 40.7 -74 90 1000 {speed}; CRE B EC35 40.7 -73.9 270 1000 {speed}")
    sim.run_until(10.0)
    warnings = [str(m) for m in sim.reporter.messages if m.kind == "warning"]
    assert len(warnings) == 2 and "limited to it" in warnings[0] and "140 kts CAS" in warnings[0]
    for acid in ("A", "B"):
        lat, lon, alt, tas = state(sim, acid)
        assert all(map(math.isfinite, (lat, lon, alt, tas)))
        assert tas == pytest.approx(139.86 * KTS, rel=1e-3)  # the EC35's maximum CAS at 1,000 ft


def test_a_moderate_overspeed_is_flown_as_bluesky_does() -> None:
    sim = make()
    sim.stack("CRE A EC35 40.7 -74 90 1000 200")  # above 140 kts, below twice that: BlueSky keeps it
    assert [m for m in sim.reporter.messages if m.kind == "warning"] == []
    assert sim.view.cas[0] == pytest.approx(200 * KTS)


@pytest.mark.parametrize("line, fragment", [
    ("CRE A EC35 40.7 -74 0 -1000000 60", "altitude outside -2,000 .. 200,000 ft"),
    ("CRE A EC35 40.7 -74 0 20000000 60", "altitude outside -2,000 .. 200,000 ft"),
    ("CRE A EC35 40.7 -74 0 FL9999 60", "flight level above FL2000"),
    ("CRE A EC35 98.3 -74 0 1000 60", "latitude"),
])
def test_positions_and_altitudes_no_aircraft_can_have_are_refused(line: str, fragment: str) -> None:
    sim = make()
    assert not sim.stack(line)
    assert sim.view.n == 0 and fragment in errors_of(sim)[0]


def test_crossing_the_antimeridian_wraps_longitude() -> None:
    sim = make()
    sim.stack("CRE A EC35 0 179.99 90 1000 100")
    sim.run_until(100.0)
    lat, lon, _, _ = state(sim, "A")
    # Flat-earth step along the equator: the longitude advances by distance / R in degrees.
    distance = sum_distance(sim, "A")
    expected = 179.99 + math.degrees(distance / R_EARTH) - 360.0
    assert -180.0 <= lon < 180.0 and lon == pytest.approx(expected, abs=1e-9) and abs(lat) < 1e-9


def sum_distance(sim: Simulation, acid: str) -> float:
    return float(sim._traffic.F[f.DISTFLOWN, sim.view.slot(acid)])


def test_flying_over_a_pole_comes_down_the_other_side() -> None:
    sim = make()
    # 0.005 deg (556 m) from the north pole, heading north at 100 kts (51.4 m/s).
    sim.stack("CRE A EC35 89.995 10 0 1000 100")
    to_pole = math.radians(0.005) * R_EARTH
    sim.run_until(10.0)
    assert sum_distance(sim, "A") < to_pole and state(sim, "A")[1] == pytest.approx(10.0)
    sim.run_until(12.0)  # the pole was crossed since
    lat, lon, _, _ = state(sim, "A")
    beyond = sum_distance(sim, "A") - to_pole
    assert 0 < beyond < 120
    # Down the other side on the meridian 10 + 180 = -170, as far from the pole as flown past it
    # (to a few metres: the heading-select autopilot starts turning back north at once).
    assert lat == pytest.approx(90.0 - math.degrees(beyond / R_EARTH), abs=5e-5)
    assert lon == pytest.approx(-170.0, abs=5.0)  # near the pole a few metres east are degrees


def test_an_aircraft_at_the_pole_heading_east_stays_finite() -> None:
    sim = make()
    sim.stack("CRE A EC35 90 0 90 1000 140")
    sim.run_until(600.0)
    lat, lon, alt, tas = state(sim, "A")
    assert all(map(math.isfinite, (lat, lon, alt, tas))) and -180.0 <= lon < 180.0 and lat <= 90.0


def test_zero_length_legs_and_a_waypoint_on_the_aircraft_stay_finite() -> None:
    sim = make()
    sim.stack("CRE A EC35 40.7 -74 0 1000 60")
    sim.stack("ADDWPT A 40.7 -74; ADDWPT A 40.7 -74; ADDWPT A 40.71 -74; ADDWPT A 40.71 -74")
    sim.run_until(120.0)
    assert errors_of(sim) == []
    assert all(map(math.isfinite, state(sim, "A")))
    assert sim._traffic.routes[0].iactwp == 3  # it flew the route to its last point


def test_a_non_finite_state_is_reported_with_the_aircraft_and_its_last_command() -> None:
    sim = make()
    sim.load_scenario("nan.scn", text="00:00:00.00>CRE A EC35 40.7 -74 0 1000 60\n"
                                      "00:00:00.00>CRE B EC35 40.8 -74 0 1000 60\n"
                                      "00:00:05.00>SPD A 80\n")
    sim.run_until(6.0)
    sim._traffic.F[f.LAT, sim.view.slot("A")] = np.nan  # what a kernel bug would do
    sim.run_until(10.0)
    errors = errors_of(sim)
    assert len(errors) == 1 and errors[0].startswith("nan.scn:3:")
    assert "A: state not finite" in errors[0] and "lat nan" in errors[0] and "SPD A 80" in errors[0]
    assert "A" not in sim.view and "B" in sim.view and sim.simt == pytest.approx(10.0)
    assert np.isfinite(sim.view.lat).all()


def test_nm_constant_sanity() -> None:
    assert 1852.0 == pytest.approx(NM)


@pytest.mark.parametrize("row", ["lat", "lon", "alt", "hdg", "trk", "tas", "cas", "mach", "gs",
                                 "gsnorth", "gseast", "vs"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_value_in_any_state_row_never_stays(row: str, bad: float) -> None:
    # The kernel sums only position, altitude and TAS. A bad value elsewhere either reaches them
    # within the step (the aircraft is removed with an error) or is recomputed from good state
    # (TAS from CAS, ground speed from TAS and track); either way no state row stays non-finite.
    sim = make()
    sim.stack("CRE A EC35 40.7 -74 45 1000 60; CRE B EC35 40.8 -74 0 1000 60; VS A 500; ALT A 3000")
    sim.run_until(2.0)
    sim._traffic.F[f.FLOAT_FIELDS.index(row), sim.view.slot("A")] = bad
    sim.run_until(4.0)
    assert "B" in sim.view
    assert np.isfinite(sim._traffic.F[f.LAT : f.VS + 1, : sim.view.n]).all()
    if "A" not in sim.view:
        assert any("A: state not finite" in e for e in errors_of(sim))
