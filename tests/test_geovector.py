"""The GEOVECTOR plugin (BlueSky's): loading, definitions and errors.

Its effect on trajectories is checked against BlueSky by the conformance
scenario tests/conformance/scenarios/geovector.scn.
"""

from __future__ import annotations

import pytest

from aamsim import Simulation
from aamsim.plugins.geovector import GeoVectors
from aamsim.units import FPM, KTS


def _run(text: str, until: float = 0.0) -> Simulation:
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.load_text(text)
    sim.run_until(until)
    return sim


def test_commands_need_the_plugin():
    sim = _run("0:0:0>BOX B 40 -75 41 -73\n0:0:0>GEOVECTOR B,,100\n")
    errors = [str(m) for m in sim.reporter.errors()]
    assert len(errors) == 1 and "PLUGINS LOAD GEOVECTOR" in errors[0]


def test_definitions_ordered_and_shown():
    sim = _run("0:0:0>PLUGIN GEOVECTOR\n0:0:0>BOX B 40 -75 41 -73\n0:0:0>GEOVECTOR B,200,100,350,10,2000,-500\n"
               "0:0:0>GEOVECTOR B\n0:0:0>GEOVECTOR C\n0:0:0>DELGEOVECTOR NONE\n")
    vec = sim.features.get(GeoVectors).vectors["B"]
    assert (vec.gsmin, vec.gsmax) == pytest.approx((100 * KTS, 200 * KTS))
    assert (vec.trkmin, vec.trkmax) == (350.0, 10.0)  # a track interval keeps its order (350..10 is valid)
    assert (vec.vsmin, vec.vsmax) == pytest.approx((-500 * FPM, 2000 * FPM))
    texts = [m.text for m in sim.reporter.messages]
    assert any(t.startswith("B: gs 100..200 kts, trk 350..10 deg") for t in texts)
    errors = [str(m) for m in sim.reporter.errors()]
    assert len(errors) == 2 and "No geovector found for C" in errors[0] and "NONE" in errors[1]


def test_track_interval_with_zero_minimum_is_kept():
    # BlueSky's "if trkmin and trkmax" drops 0..30; aamsim applies it.
    sim = _run("0:0:0>PLUGIN GEOVECTOR\n0:0:0>BOX B 40 -75 41 -73\n0:0:0>GEOVECTOR B,,,0,30\n"
               "0:0:0>CRE A EC35 40.5 -74 90 1500 100\n", until=30)
    assert sim.view.hdg[0] == pytest.approx(30.0)


def test_speed_limit_and_restore_of_lnav_after_exit():
    sim = _run("0:0:0>PLUGIN GEOVECTOR\n0:0:0>BOX B 40 -74.02 41 -73.99\n0:0:0>GEOVECTOR B,,,80,100\n"
               "0:0:0>CRE A EC35 40.5 -74.01 0 1500 100\n0:0:0>ADDWPT A 40.6 -73.95\n", until=2)
    assert not sim.view.lnav[0]  # turned to 80 deg: LNAV off inside
    sim.run_until(200)
    assert sim.view.lnav[0]  # out of the box (east of -73.99): LNAV back on, as at entry
