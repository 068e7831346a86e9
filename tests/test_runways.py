"""Runway positions from BlueSky's navigation data (``EHAM/RW18C``, ``EHAM RW18C``)."""

from __future__ import annotations

import math

import pytest

from aamsim import Simulation
from aamsim.navdb import NavDatabase, _threshold, bluesky_airports

pytestmark = pytest.mark.skipif(not bluesky_airports(), reason="needs BlueSky's navigation data")


def test_displaced_threshold_on_the_sphere():
    # Due north along a meridian: the threshold moves offset/R radians of latitude, bearing 0.
    lat, lon, brg = _threshold(52.0, 4.0, 53.0, 4.0, 1000.0)
    assert lat == pytest.approx(52.0 + math.degrees(1000.0 * 1.56961231e-7), abs=1e-12)
    assert lon == pytest.approx(4.0, abs=1e-12) and brg == pytest.approx(0.0, abs=1e-9)
    lat, lon, brg = _threshold(0.0, 10.0, 0.0, 9.0, 0.0)  # due west on the equator, no displacement
    assert (lat, lon) == (0.0, 10.0) and brg == pytest.approx(270.0)


def test_runway_thresholds_as_bluesky_reads_them():
    navdb = NavDatabase()
    # Values printed by BlueSky 1.1.1 (bs.navdb.rwythresholds['EHAM']['18C'] and ['36L']).
    lat, lon, brg = navdb.runway("EHAM/RW18C")
    assert (lat, lon) == pytest.approx((52.33139701999999, 4.74011451), abs=1e-12)
    assert brg == pytest.approx(183.19786882783455, abs=1e-9)
    assert navdb.runway("EHAM/RWY36L")[:2] == pytest.approx((52.328458, 4.70890493), abs=1e-12)
    assert navdb.runway("EHAM/RW99") is None and navdb.runway("XXXX/RW18") is None
    assert navdb.known("EHAM/RW18C") and not navdb.known("EHAM/RW99")


def test_runway_positions_in_commands():
    sim = Simulation(seed=0)
    sim.load_text("0:0:0>CRE A1 B744 EHAM/RW18C,,0,150\n0:0:0>CRE A2 B744 EHAM RW36L 10 0 150\n"
                  "0:0:0>CRE A3 B744 52 4 90 FL100 250\n0:0:0>DEST A3 EHAM/RW18C\n0:0:0>DEST A2 EHAM/RW99\n")
    sim.run_until(0)
    v = sim.view
    a1, a2 = v.find("A1"), v.find("A2")
    assert (v.lat[a1], v.lon[a1]) == pytest.approx((52.33139701999999, 4.74011451), abs=1e-12)
    assert v.hdg[a1] == pytest.approx(183.19786882783455)  # no heading given: the runway's, as BlueSky
    assert (v.lat[a2], v.lon[a2], v.hdg[a2]) == pytest.approx((52.328458, 4.70890493, 10.0))
    dest = v.route(v.find("A3")).waypoints[-1]
    assert (dest.lat, dest.lon) == pytest.approx((52.33139701999999, 4.74011451), abs=1e-12)
    errors = [str(m) for m in sim.reporter.errors()]
    assert len(errors) == 1 and "EHAM/RW99" in errors[0]
