"""RESO MVP: BlueSky's Modified Voltage Potential resolution (aamsim/resolution/mvp*.py, the RESO commands).

The arithmetic is checked on hand-worked geometries; agreement with BlueSky over
whole encounters is checked by the conformance scenarios mvp_headon and
mvp_crossing (tests/conformance), recorded from BlueSky 1.1.1.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from aamsim import Simulation
from aamsim.resolution.mvp import MVPSettings, OwnState, PairGeometry, combine, commands, mvp_pairs
from aamsim.resolution.mvp_detect import detect


def geometry(drel, vrel, tcpa, tlos, own=(0,), intr=(1,)) -> PairGeometry:
    return PairGeometry(np.array(own), np.array(intr), np.array([drel], dtype=float),
                        np.array([vrel], dtype=float), np.array([tcpa], dtype=float), np.array([tlos], dtype=float))


# ------------------------------------------------------------------------------------------ the push
def test_push_inside_the_zone_is_the_intrusion_over_the_time_to_cpa():
    # Intruder 300 m east, 100 m north, closing west at 30 m/s: CPA in 10 s, 100 m north.
    # Within the 500 m zone: push = (500 - 100) m along (0, 1), over 10 s = (0, 40) m/s.
    # Vertically no closure, 100 m apart in a 300 m zone: (300 - 100) m over tLOS (-4 s) = -50 m/s.
    push, tsol = mvp_pairs(geometry((300, 100, 100), (-30, 0, 0), 10.0, -4.0), 500.0, 300.0, 60.0)
    assert push[0] == pytest.approx([0.0, 40.0, -50.0])
    assert tsol[0] == -4.0


def test_push_outside_the_zone_aims_at_the_tangent():
    # Intruder 1000 m east, 100 m north, closing at 100 m/s: CPA in 10 s, 100 m north.
    # Outside the 500 m zone the push is rpz / cos(asin(500/d) - asin(100/d)) - 100, d = 1005 m.
    d = math.hypot(1000, 100)
    erratum = math.cos(math.asin(500 / d) - math.asin(100 / d))  # 0.91269
    expected = (500 / erratum - 100) * 100 / (10 * 100)  # 44.785 m/s north
    push, _ = mvp_pairs(geometry((1000, 100, 0), (-100, 0, 0), 10.0, 5.0), 500.0, 300.0, 60.0)
    assert expected == pytest.approx(44.785, abs=1e-3)
    assert push[0][:2] == pytest.approx([0.0, expected])


def test_head_on_is_pushed_sideways():
    # Exactly head-on: miss distance 0, taken as 10 m perpendicular to the line of sight,
    # (dy, -dx) / d * 10 = (0, -10): the push points south, so the ownship turns north.
    erratum = math.cos(math.asin(0.5) - math.asin(0.01))
    expected = -(500 / erratum - 10) * 10 / (10 * 10)  # -56.40 m/s
    push, _ = mvp_pairs(geometry((1000, 0, 0), (-100, 0, 0), 10.0, 5.0), 500.0, 300.0, 60.0)
    assert push[0][:2] == pytest.approx([0.0, expected])
    assert expected == pytest.approx(-56.406, abs=1e-3)


def test_vertical_push_against_the_closure_over_the_time_to_co_altitude():
    # Intruder 200 m above, descending towards the ownship at 4 m/s: co-altitude in 50 s;
    # the push is the 300 m zone over 50 s = 6 m/s, against the relative vertical speed (up).
    push, tsol = mvp_pairs(geometry((300, 100, 200), (-30, 0, -4), 10.0, 2.0), 500.0, 300.0, 60.0)
    assert push[0][2] == pytest.approx(6.0) and tsol[0] == pytest.approx(50.0)
    # Co-altitude beyond the look-ahead: the zone over the time to loss of separation instead.
    push, tsol = mvp_pairs(geometry((300, 100, 200), (-30, 0, -1), 10.0, 8.0), 500.0, 300.0, 60.0)
    assert push[0][2] == pytest.approx(300.0 / 8.0) and tsol[0] == 8.0


# ------------------------------------------------------------------------------- per aircraft
def test_pairs_add_up_and_each_aircraft_takes_half_the_vertical():
    g = PairGeometry(np.array([0, 0, 1]), np.array([1, 2, 0]), np.zeros((3, 3)), np.zeros((3, 3)), np.ones(3),
                     np.ones(3))
    push = np.array([[1.0, 2.0, 4.0], [10.0, 0.0, 2.0], [-1.0, -2.0, -4.0]])
    tsol = np.array([30.0, 20.0, 30.0])
    none = np.zeros(3, dtype=bool)
    dv, tsolv = combine(3, g, push, tsol, MVPSettings(), np.zeros(3), none, none)
    assert dv[0].tolist() == [-11.0, -2.0, -3.0]  # -(1 + 10), -(2 + 0), -(4 + 2) / 2
    assert dv[1].tolist() == [1.0, 2.0, 2.0]
    assert dv[2].tolist() == [0.0, 0.0, 0.0] and tsolv.tolist() == [20.0, 30.0, 1e9]
    # NORESO 1: nobody avoids aircraft 1 (0 keeps only its push from 2); RESOOFF 2 changes nothing for 2.
    dv, _ = combine(3, g, push, tsol, MVPSettings(), np.zeros(3), np.array([False, True, False]), none)
    assert dv[0].tolist() == [-10.0, 0.0, -1.0]
    dv, _ = combine(3, g, push, tsol, MVPSettings(), np.zeros(3), none, np.array([True, False, False]))
    assert dv[0].tolist() == [0.0, 0.0, 0.0] and dv[1].tolist() == [1.0, 2.0, 2.0]


def test_priority_rules_ff2_lets_the_cruising_aircraft_keep_its_path():
    g = PairGeometry(np.array([0, 1]), np.array([1, 0]), np.zeros((2, 3)), np.zeros((2, 3)), np.ones(2),
                     np.ones(2))
    push = np.array([[1.0, 0.0, 2.0], [-1.0, 0.0, -2.0]])
    settings = MVPSettings()
    settings.set_priority(True, "FF2")
    none = np.zeros(2, dtype=bool)
    dv, _ = combine(2, g, push, np.ones(2), settings, np.array([0.0, 5.0]), none, none)  # 0 cruises, 1 climbs
    assert dv[0].tolist() == [0.0, 0.0, 0.0] and dv[1].tolist() == [1.0, 0.0, 1.0]
    settings.set_priority(True, "LAY2")  # climbing has priority, horizontal only: 0 resolves
    dv, _ = combine(2, g, push, np.ones(2), settings, np.array([0.0, 5.0]), none, none)
    assert dv[0].tolist() == [-1.0, 0.0, 0.0] and dv[1].tolist() == [0.0, 0.0, 0.0]


def own_state(**changes) -> OwnState:
    base = {"gseast": 0.0, "gsnorth": 50.0, "vs": 0.0, "trk": 0.0, "gs": 50.0, "alt": 500.0, "selalt": 500.0,
            "ap_vs": 0.0, "vmin": 0.0, "vmax": 60.0, "vsmin": -5.0, "vsmax": 5.0}
    base.update(changes)
    return OwnState(**{k: np.array([v], dtype=float) for k, v in base.items()})


def test_commands_heading_and_speed_by_default_capped_to_the_envelope():
    dv = np.array([[10.0, 0.0, 3.0]])
    trk, gs, vs, alt = commands(own_state(), dv, np.array([20.0]), MVPSettings(), 60.0)
    assert trk[0] == pytest.approx(math.degrees(math.atan2(10, 50)))  # 11.31 deg
    assert gs[0] == pytest.approx(math.hypot(10, 50)) and vs[0] == 0.0 and alt[0] == 500.0
    trk, gs, _, _ = commands(own_state(vmax=50.0), dv, np.array([20.0]), MVPSettings(), 60.0)
    assert gs[0] == 50.0  # capped


def test_commands_limited_to_speed_heading_or_vertical():
    dv = np.array([[10.0, -20.0, 3.0]])
    s = MVPSettings()
    s.set_horizontal("SPD")
    trk, gs, _, _ = commands(own_state(), dv, np.array([20.0]), s, 60.0)
    assert trk[0] == 0.0 and gs[0] == pytest.approx(math.hypot(10, 30))
    s.set_horizontal("HDG")
    trk, gs, _, _ = commands(own_state(), dv, np.array([20.0]), s, 60.0)
    assert trk[0] == pytest.approx(math.degrees(math.atan2(10, 30))) and gs[0] == 50.0
    s.set_vertical("ON")
    trk, gs, vs, alt = commands(own_state(), dv, np.array([20.0]), s, 60.0)
    # Vertical only: 3 m/s for the 20 s to resolve, from 500 m: 560 m.
    assert trk[0] == 0.0 and gs[0] == 50.0 and vs[0] == 3.0 and alt[0] == pytest.approx(560.0)


# ---------------------------------------------------------------------------------- end to end
HEAD_ON = (
    "00:00:00.00>ASAS ON\n00:00:00.00>ZONER 0.3\n00:00:00.00>ZONEDH 300\n00:00:00.00>DTLOOK 60\n"
    "00:00:00.00>CRE A EC35 40.70 -74.00 90 1500 120\n00:00:00.00>ADDWPT A 40.70 -73.85\n"
    "00:00:00.00>CRE B EC35 40.70 -73.90 270 1500 120\n00:00:00.00>ADDWPT B 40.70 -74.05\n"
)


def closest_approach(text: str, until: float = 200.0) -> tuple[float, Simulation]:
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.services.start()
    sim.load_text(text)
    best = math.inf
    while sim.simt < until:
        sim.run_until(sim.simt + 1.0)
        v = sim.view
        dx = math.radians(v.lon[1] - v.lon[0]) * math.cos(math.radians(v.lat[0])) * 6371000.0
        dy = math.radians(v.lat[1] - v.lat[0]) * 6371000.0
        best = min(best, math.hypot(dx, dy))
    return best, sim


def test_reso_mvp_separates_a_head_on_pair_and_resumes_the_routes():
    unresolved, _ = closest_approach(HEAD_ON)
    resolved, sim = closest_approach("00:00:00.00>RESO MVP\n" + HEAD_ON)
    assert unresolved < 50.0
    assert resolved > 0.3 * 1852.0  # beyond the protected zone
    assert not sim.view.resolution.any()  # past CPA: both back on their routes (LNAV on)
    assert sim.view.lnav.all()
    # Only A, created first, resolves: BlueSky's detection mirrors the intruder's position for the
    # later aircraft of a pair (aamsim/resolution/mvp_detect.py), which sees no conflict while closing.
    assert sim.services.mvp.resolutions == 1
    assert [f.advisories for f in sim.flights()] == [1, 0]


def errors_of(sim: Simulation) -> list[str]:
    return [str(m) for m in sim.reporter.messages if m.kind == "error"]


def test_bad_reso_input_is_reported_with_its_line_and_the_run_goes_on():
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.load_text(
        "00:00:00.00>RESO SSD\n"
        "00:00:00.00>RESO FANCY\n"
        "00:00:00.00>RMETHH SIDEWAYS\n"
        "00:00:00.00>RMETHV UP\n"
        "00:00:00.00>PRIORULES ON FF9\n"
        "00:00:00.00>RFACH -2\n"
        "00:00:00.00>NORESO NOSUCH\n"
        "00:00:00.00>RESO MVP\n" + HEAD_ON, name="bad.scn")
    sim.run_until(120.0)
    errors = errors_of(sim)
    assert len(errors) == 7, errors
    assert "bad.scn:1" in errors[0] and "BlueSky plugin" in errors[0] and "OFF, MVP, DAA" in errors[0]
    assert "bad.scn:2" in errors[1] and "no such resolution method" in errors[1]
    assert "RMETHH 'SIDEWAYS' not understood" in errors[2] and "RMETHV 'UP'" in errors[3]
    assert "FF9" in errors[4] and "RFACH" in errors[5] and "NOSUCH" in errors[6]
    # The valid lines took effect: MVP resolves with the default settings.
    assert sim.settings.reso == "MVP" and sim.services.mvp.settings == MVPSettings()
    assert sim.services.mvp.resolutions == 1 and sim.simt == 120.0


def test_settings_commands_and_reso_off_release():
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.load_text("00:00:00.00>RESO MVP\n00:00:00.00>RMETHH SPD\n00:00:00.00>RFACV 1.2\n"
                  "00:00:00.00>PRIORULES ON LAY1\n" + HEAD_ON)
    sim.run_until(5.0)
    s = sim.services.mvp.settings
    assert (s.horizontal, s.speed, s.heading, s.factor_v, s.priority, s.priority_code) == (
        True, True, False, 1.2, True, "LAY1")
    assert sim.view.resolution.any()
    # RSZONER keeps its radius when ZONER changes (as BlueSky).
    sim.stack("RSZONER 0.6")
    assert s.factor_h == pytest.approx(2.0)
    sim.stack("ZONER 0.4")
    assert s.factor_h * sim.settings.zoner_m == pytest.approx(0.6 * 1852.0)
    sim.stack("NORESO A B; NORESO B")
    assert sim.services.mvp.no_reso == {"A"}
    sim.stack("RESO OFF")
    sim.run_until(7.0)
    assert not sim.view.resolution.any() and not errors_of(sim)


def test_bluesky_pairs_mirror_the_later_aircraft_side():
    # BlueSky's compiled bearing matrix copies the upper triangle into the lower one: while a
    # head-on pair closes only the earlier aircraft (A) has the conflict; once past each
    # other, only the later one (B), which sees A's position mirrored, as still ahead.
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.load_text("00:00:00.00>CRE A EC35 40.70 -74.00 90 1500 120\n"
                  "00:00:00.00>CRE B EC35 40.7001 -73.95 270 1500 120\n")
    sim.run_until(1.0)
    conf = detect(sim, 500.0, 100.0, 60.0)
    assert list(zip(conf.own.tolist(), conf.intr.tolist())) == [(0, 1)]
    assert conf.qdr_deg[0] == pytest.approx(90.0, abs=0.5) and 0.0 < conf.tlos_s[0] < conf.tcpa_s[0]
    sim.run_until(45.0)  # they met at about 33 s
    conf = detect(sim, 500.0, 100.0, 60.0)
    assert list(zip(conf.own.tolist(), conf.intr.tolist())) == [(1, 0)]
    assert conf.qdr_deg[0] == pytest.approx(-90.0, abs=0.5)  # A to B; from B, A lies at +90 deg: mirrored
    assert conf.tcpa_s[0] > 0.0


def test_aamsim_run_with_reso_mvp_keeps_the_head_on_pair_apart(tmp_path):
    root = Path(__file__).resolve().parents[1]
    summaries = {}
    for name, text in (("off", HEAD_ON), ("on", "00:00:00.00>RESO MVP\n" + HEAD_ON)):
        (tmp_path / f"{name}.scn").write_text(text)
        proc = subprocess.run([sys.executable, "-m", "aamsim", "run", f"{name}.scn", "--until", "200", "--out", name,
                               "--quiet"], cwd=tmp_path, env=dict(os.environ, PYTHONPATH=str(root)),
                              capture_output=True, text=True, timeout=600, check=False)
        assert proc.returncode == 0, proc.stderr
        summaries[name] = json.loads((tmp_path / name / "summary.json").read_text())
    off, on = summaries["off"], summaries["on"]
    assert off["safety"]["nmac_events"] == 1 and "mvp" not in off
    assert on["safety"]["lowc_events"] == 0 and on["safety"]["min_separation_m"] > 450.0
    assert on["mvp"]["resolutions_started"] == 1 and "RFACH 1.05" in on["mvp"]["settings"]
