"""Shapes (BOX, CIRCLE, POLY, POLYALT, LINE) and BlueSky's area plugin (AREA, EXP, TAXI).

Hand-computed cases; the trajectory-level agreement with BlueSky is the
conformance scenario tests/conformance/scenarios/area.scn.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from aamsim import Simulation
from aamsim.deletion_area import DeletionArea
from aamsim.shapes import kwikdist_nm, shapes_of
from aamsim.units import FT, KTS, NM


def _sim(text: str) -> Simulation:
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.load_text(text)
    return sim


def _errors(sim: Simulation) -> list[str]:
    return [str(m) for m in sim.reporter.errors()]


def test_box_includes_its_bounds_and_altitude_band():
    sim = _sim("0:0:0>BOX B 40.0 -74.0 41.0 -73.0 FL100 1000\n")
    sim.run_until(0)
    shape = shapes_of(sim).get("B")
    assert shape is not None and shape.top_m == 10000 * FT and shape.bottom_m == 1000 * FT
    lat = np.array([40.0, 41.0, 40.5, 40.5, 40.5, 39.9999])
    lon = np.array([-74.0, -73.0, -73.5, -73.5, -73.5, -73.5])
    alt = np.array([1000 * FT, 10000 * FT, 999 * FT, 10001 * FT, 5000 * FT, 5000 * FT])
    assert shape.contains(lat, lon, alt).tolist() == [True, True, False, False, True, False]


def test_circle_uses_bluesky_kwikdist():
    # 1 nm north of the centre: dlat = 1852 / 6371000 rad.
    dlat = math.degrees(NM / 6371000.0)
    assert kwikdist_nm(40.0, -74.0, np.array([40.0 + dlat]), np.array([-74.0]))[0] == pytest.approx(1.0, rel=1e-12)
    # East-west uses the cosine of the mean latitude.
    dlon = math.degrees(NM / (6371000.0 * math.cos(math.radians(40.0))))
    assert kwikdist_nm(40.0, -74.0, np.array([40.0]), np.array([-74.0 + dlon]))[0] == pytest.approx(1.0, rel=1e-12)
    sim = _sim("0:0:0>CIRCLE C 40.0 -74.0 1.0\n")
    sim.run_until(0)
    inside = shapes_of(sim).get("C").contains(np.array([40.0 + 0.999 * dlat, 40.0 + 1.001 * dlat]),
                                               np.array([-74.0, -74.0]), np.zeros(2))
    assert inside.tolist() == [True, False]


def test_polygon_and_polyalt():
    sim = _sim("0:0:0>POLY TRI 0 0 2 1 0 2\n0:0:0>POLYALT HI FL200 FL100 0 0 2 1 0 2\n")
    sim.run_until(0)
    shapes = shapes_of(sim)
    lat, lon = np.array([0.5, 1.5, 1.0]), np.array([1.0, 0.2, 1.0])
    assert shapes.contains("TRI", lat, lon, np.zeros(3)).tolist() == [True, False, True]
    alt = np.array([15000 * FT, 15000 * FT, 5000 * FT])
    assert shapes.contains("HI", lat, lon, alt).tolist() == [True, False, False]
    assert shapes.contains("NONE", lat, lon, alt).tolist() == [False, False, False]


def test_del_removes_a_shape_and_bad_shapes_are_errors():
    sim = _sim("0:0:0>BOX B 0 0 1 1\n0:0:0>DEL B\n0:0:0>POLY P 0 0 1 1\n0:0:0>CIRCLE C 0 0 -1\n0:0:0>DEL NOTHING\n")
    sim.run_until(0)
    assert shapes_of(sim).names() == []
    errors = _errors(sim)
    assert any("polygon P needs at least three" in e for e in errors)
    assert any("radius -1 nm" in e for e in errors)
    assert any("no aircraft NOTHING" in e for e in errors)


def _flight_time(dist_deg_lon: float, lat: float, kts: float) -> float:
    return math.radians(dist_deg_lon) * 6371000.0 * math.cos(math.radians(lat)) / (kts * KTS)


def test_aircraft_leaving_the_area_is_deleted_at_the_next_one_second_test():
    # EC35 at 1500 ft, 100 kts CAS (TAS a little higher): leaves the box 0.01 deg of longitude east.
    sim = _sim("0:0:0>AREA 40.6 -74.05 40.8 -74.00\n0:0:0>CRE A EC35 40.7 -74.01 90 1500 100\n"
               "0:0:0>CRE B EC35 40.7 -73.99 90 1500 100\n")
    times = {}
    for t in range(1, 60):
        sim.run_until(t)
        for acid in ("A", "B"):
            if acid not in sim.view and acid not in times:
                times[acid] = t
    tas = float(sim.view.tas[sim.slot("B")]) / KTS
    crossing = _flight_time(0.01, 40.7, tas)
    assert times == {"A": math.ceil(crossing)}  # B was created outside: never deleted
    record = next(r for r in sim.flight_log if r.acid == "A")
    assert not record.arrived and record.deleted_s == times["A"]


def test_area_altitude_band_climbing_out_deletes():
    sim = _sim("0:0:0>AREA 40 -75 41 -73 2000 0\n0:0:0>CRE A EC35 40.5 -74 90 1500 100\n0:0:5>ALT A 3000 1500\n")
    sim.run_until(80)
    assert "A" not in sim.view
    record = sim.flight_log[-1]
    # 1500 fpm = 7.62 m/s: 500 ft (152.4 m) in 20 s plus the 300 fpm/s ramp; tests every whole second.
    assert 25 <= record.deleted_s <= 28 and record.deleted_s == int(record.deleted_s)


def test_area_off_and_experiment_area_delete_nothing():
    sim = _sim("0:0:0>EXP 40.6 -74.05 40.8 -74.00\n0:0:0>CRE A EC35 40.7 -74.01 90 1500 100\n")
    sim.run_until(60)
    assert "A" in sim.view and not _errors(sim)
    sim = _sim("0:0:0>AREA 40.6 -74.05 40.8 -74.00\n0:0:0>CRE A EC35 40.7 -74.01 90 1500 100\n0:0:5>AREA OFF\n")
    sim.run_until(60)
    assert "A" in sim.view


def test_area_errors():
    sim = _sim("0:0:0>AREA NOSUCHSHAPE\n0:0:0>AREA 1 2 3\n0:0:0>AREA 1 2 3 4 5 6 7\n0:0:0>AREA ON\n")
    sim.run_until(0)
    errors = _errors(sim)
    assert len(errors) == 4
    assert "shape NOSUCHSHAPE unknown" in errors[0] and "Incorrect arguments" in errors[1]
    assert "extra argument" in errors[2] and "No area defined" in errors[3]


def test_taxi_off_deletes_aircraft_descending_through_its_altitude():
    text = ("0:0:0>TAXI OFF 1200\n0:0:0>CRE HI EC35 40 -74 90 2000 100\n0:0:0>ALT HI 800 1000\n"
            "0:0:0>CRE LOW EC35 40 -74.1 90 1000 100\n0:0:0>ALT LOW 500 1000\n")
    sim = _sim(text)
    sim.run_until(120)
    assert "LOW" in sim.view  # created below 1200 ft: it never descends through it
    record = next(r for r in sim.flight_log if r.acid == "HI")
    # 800 ft at 1000 fpm (5.08 m/s) after a 300 fpm/s ramp: 2000 -> 1200 ft after about 49 s.
    assert 47 <= record.deleted_s <= 51 and record.deleted_s == int(record.deleted_s)
    sim = _sim(text.replace("TAXI OFF 1200", "TAXI ON"))
    sim.run_until(120)
    assert "HI" in sim.view


def test_reset_clears_shapes_and_area():
    sim = _sim("0:0:0>BOX B 40 -75 41 -73\n0:0:0>AREA B\n0:0:1>RESET\n")
    sim.run_until(2)
    assert shapes_of(sim).names() == []
    area = sim.features.get(DeletionArea)
    assert not area.active and area.delarea == ""


def test_two_simulations_keep_their_own_areas():
    a = _sim("0:0:0>BOX B 40 -75 41 -73\n")
    b = _sim("0:0:0>BOX C 0 0 1 1\n")
    a.run_until(0)
    b.run_until(0)
    assert shapes_of(a).names() == ["B"] and shapes_of(b).names() == ["C"]
