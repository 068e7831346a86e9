"""AFTER / BEFORE (waypoint insertion), CALC and RTF, as in BlueSky."""

from __future__ import annotations

import pytest

from aamsim import Simulation
from aamsim.calculator import CalcError, calculate


def _run(text: str) -> Simulation:
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.load_text(text)
    sim.run_until(0)
    return sim


def test_after_and_before_insert_waypoints():
    sim = _run("0:0:0>DEFWPT P1 52 4\n0:0:0>DEFWPT P2 52 5\n0:0:0>DEFWPT NEW 52.5 4.5\n"
               "0:0:0>CRE KL204 B744 51.9 3.9 90 FL100 250\n0:0:0>ADDWPT KL204 P1\n0:0:0>ADDWPT KL204 P2\n"
               "0:0:0>KL204 AFTER P1 ADDWPT NEW FL120 260\n0:0:0>BEFORE KL204 P1 ADDWPT 51.95 3.95\n")
    route = sim.view.route(0)
    assert [w.name for w in route.waypoints] == ["KL204001", "P1", "NEW", "P2"]
    assert route.waypoints[2].alt == pytest.approx(12000 * 0.3048)
    assert not sim.reporter.errors()


def test_after_errors():
    sim = _run("0:0:0>CRE A B744 52 4 90 FL100 250\n0:0:0>AFTER A NOWHERE ADDWPT 52 5\n0:0:0>AFTER A X Y\n")
    errors = [str(m) for m in sim.reporter.errors()]
    assert len(errors) == 2 and "NOWHERE is not in the route" in errors[0] and "usage: AFTER" in errors[1]


def test_calc_arithmetic_only():
    assert calculate("2^10 + sind(30)") == 1024.5
    assert calculate("deg(52, 30, 0)") == 52.5
    assert calculate("sqrt(16) * pi") == pytest.approx(12.566370614359172)
    for bad in ("bs.traf.ntraf", "__import__('os')", "open('x')", "9**9**9", "1/0", "x" * 2000):
        with pytest.raises(CalcError):
            calculate(bad)
    sim = _run("0:0:0>CALC 1+2\n0:0:0>CALC bs.traf.ntraf\n0:0:0>RTF 10\n")
    kinds = [(m.kind, m.text) for m in sim.reporter.messages]
    assert ("echo", "1+2 = 3") in kinds or any(t == "1+2 = 3" for _, t in kinds)
    assert not sim.reporter.errors()
    assert any(k == "warning" and "bs.traf.ntraf" in t for k, t in kinds)
