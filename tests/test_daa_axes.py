"""RESO DAA on every axis: heading and vertical-speed bands, preferred direction, coordination, end to end.

Geometry by hand: two aircraft at one speed V head-on, D apart; the ownship turning by
theta (the intruder straight) has the relative velocity V (sin h + 1, cos h) and the miss
distance ``d_cpa = D sin(theta / 2)``, so the conflict band of its track is
``90 +- 2 asin(HMD / D)`` (HMD = DMOD = 450 m: the band edge is where ``d_cpa = 450 m``).
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
from aamsim.resolution.axes import HDG, LEFT_DOWN, RIGHT_UP, VS, AxisResolver, heading_directions, linear_directions
from aamsim.resolution.daa import DAAParams, DetectAndAvoid
from aamsim.units import R_EARTH

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data"
ENV = dict(os.environ, PYTHONPATH=str(ROOT))


def two(lines: list[str]) -> Simulation:
    sim = Simulation(seed=0)
    sim.services.start()
    for line in lines:
        sim.stack(line)
    sim.run_until(0.0)
    return sim


def test_free_values_closest_in_each_direction_kept_a_margin_inside_the_bands():
    # Linear (vertical speed): bands [-3, 3] in [-5, 5], margin 0.5.
    assert linear_directions([(-3.0, 3.0)], -5.0, 5.0, 0.0, 0.5) == (3.5, -3.5)
    # Only one side free; nothing free.
    up, down = linear_directions([(-5.0, 3.0)], -5.0, 5.0, 0.0, 0.5)
    assert up == 3.5 and math.isnan(down)
    assert all(math.isnan(x) for x in linear_directions([(-5.0, 5.0)], -5.0, 5.0, 0.0, 0.5))
    # Heading from 80 deg, band 70..100 and 200..260: right 20 + 5, left 10 + 5.
    assert heading_directions([(70.0, 100.0), (200.0, 260.0)], 80.0, 5.0, 180.0) == pytest.approx((25.0, 15.0))
    # A band across north (two rows) and the turn limit.
    right, left = heading_directions([(350.0, 360.0), (0.0, 30.0)], 10.0, 5.0, 180.0)
    assert (right, left) == pytest.approx((25.0, 25.0))
    right, left = heading_directions([(350.0, 360.0), (0.0, 30.0)], 10.0, 5.0, 20.0)
    assert math.isnan(right) and math.isnan(left)


HEAD_ON = ["CRE OW1 EC35 40.70 -74.02 090 1000 120", "CRE IN1 EC35 40.70 -73.95 270 1000 120"]


def test_head_on_heading_bands_and_both_turn_right():
    sim = two(HEAD_ON)
    daa = DetectAndAvoid()
    resolver = AxisResolver(daa)
    slots = np.array([sim.view.slot("OW1"), sim.view.slot("IN1")])
    bands = resolver.bands(sim, HDG, slots)
    dist = R_EARTH * math.radians(0.07) * math.cos(math.radians(40.70))
    theta = math.degrees(2.0 * math.asin(450.0 / dist))  # 8.75 deg
    (lo, hi), = bands.of(int(slots[0]))
    assert (lo, hi) == pytest.approx((90.0 - theta, 90.0 + theta), abs=0.02)
    (lo, hi), = bands.of(int(slots[1]))
    assert (lo, hi) == pytest.approx((270.0 - theta, 270.0 + theta), abs=0.02)
    # Symmetric: s x v = 0, both take eps = +1 and turn right (by the band plus the 5 deg margin).
    urgent = slots[::-1]
    assert resolver.senses(sim, HDG, slots, urgent).tolist() == [RIGHT_UP, RIGHT_UP]
    res = resolver.resolve(sim, HDG, slots, bands, urgent)
    assert [r.value for r in res] == pytest.approx([90.0 + theta + 5.0, 270.0 + theta + 5.0], abs=0.02)
    assert [r.direction for r in res] == [RIGHT_UP, RIGHT_UP]


def test_overtaking_turns_apart_and_vertical_senses_split_a_pair():
    sim = two(["CRE O1 EC35 40.90 -74.00 090 1000 120", "CRE O2 EC35 40.90 -73.9644 090 1000 60"])
    resolver = AxisResolver(DetectAndAvoid())
    slots = np.array([sim.view.slot("O1"), sim.view.slot("O2")])
    # Collinear (s x v = 0, eps = +1): the one behind (intruder ahead) turns right, the one ahead left,
    # so both turns grow the same miss vector.
    assert resolver.senses(sim, HDG, slots, slots[::-1]).tolist() == [RIGHT_UP, LEFT_DOWN]
    # Vertically the higher aircraft climbs; at one altitude the callsign that sorts first does.
    assert resolver.senses(sim, VS, slots, slots[::-1]).tolist() == [RIGHT_UP, LEFT_DOWN]
    sim.stack("ALT O2 1100")
    sim.run_until(60.0)
    assert resolver.senses(sim, VS, slots, slots[::-1]).tolist() == [LEFT_DOWN, RIGHT_UP]


def test_vertical_speed_band_of_a_head_on_pair_by_hand():
    # Same geometry, the intruder 600 ft higher: the horizontal violation interval [a, b] does not depend
    # on the vertical speed; climbing at vz the ownship is within ZTHR of the intruder from
    # (-ZTHR - dz) / vz on, so it loses well clear iff vz >= (-ZTHR - dz) / b (and until (ZTHR - dz) / a,
    # beyond the 1000 fpm limit). Descending never does.
    sim = two(["CRE OW1 EC35 40.70 -74.02 090 1000 120", "CRE IN1 EC35 40.70 -73.95 270 1600 120"])
    p = DAAParams()
    resolver = AxisResolver(DetectAndAvoid(p))
    own = sim.view.slot("OW1")
    bands = resolver.bands(sim, VS, np.array([own]))
    from aamsim.conflicts.wellclear import horizontal_interval

    dist = R_EARTH * math.radians(0.07) * math.cos(math.radians(40.70))
    v = float(sim.view.gs[own]) + float(sim.view.gs[sim.view.slot("IN1")])  # closing speed (TAS differs by altitude)
    a, b = horizontal_interval(-dist, 0.0, v, 0.0, p.dmod_m, p.hmd_m, p.taumod_s)
    dz = -600.0 * 0.3048  # the ownship relative to the intruder
    assert (p.zthr_m - dz) / a > p.vs_max_mps
    (lo, hi), = bands.of(own)
    assert (lo, hi) == pytest.approx(((-p.zthr_m - dz) / b, p.vs_max_mps), abs=1e-5)
    # Level flight is conflict-free: the closest free vertical speed is the current one.
    assert not bands.conflicts(own, 0.0) and bands.conflicts(own, lo + 0.1)
    res, = resolver.resolve(sim, VS, np.array([own]), bands, np.array([sim.view.slot("IN1")]))
    assert res.value == 0.0


def run_cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], cwd=cwd, env=ENV, capture_output=True, text=True, timeout=900,
                          check=False)


def test_reso_daa_on_every_axis_resolves_head_on_crossing_and_overtaking(tmp_path):
    text = (DATA / "daa_turns.scn").read_text()
    on = tmp_path / "turns_daa.scn"
    # A bad axis is reported with its file and line; the run goes on with the default axes.
    on.write_text("00:00:00.00>RESO DAA\n00:00:00.00>DAA RESOAXES HDG FOO\n" + text)
    gs_only = tmp_path / "turns_gs.scn"
    gs_only.write_text("00:00:00.00>RESO DAA\n00:00:00.00>DAA RESOAXES GS\n" + text)
    out = {}
    for name, scn in (("off", DATA / "daa_turns.scn"), ("on", on), ("gs", gs_only)):
        proc = run_cli(["-m", "aamsim", "run", str(scn), "--until", "300", "--out", name, "--quiet"], tmp_path)
        assert proc.returncode == 0, proc.stderr
        out[name] = (json.loads((tmp_path / name / "summary.json").read_text()), proc.stderr)
    off, (daa, stderr), gs = out["off"][0], out["on"], out["gs"][0]
    assert off["safety"]["nmac_events"] == 3  # each encounter, unequipped
    assert gs["safety"]["nmac_events"] >= 1  # the head-on pair: no speed resolves it
    assert daa["safety"]["nmac_events"] == 0 and daa["safety"]["lowc_events"] == 0
    assert daa["safety"]["min_separation_m"] > 450.0
    assert daa["daa"]["advisories_by_axis"]["heading"] >= 3
    assert "turns_daa.scn:2" in stderr and "unknown DAA resolution axis 'FOO'; known: HDG, VS, GS" in stderr
    assert daa["daa"]["params"]["resolution_axes"] == ["hdg", "vs", "gs"]


def test_daa_resoaxes_command_sets_lists_and_rejects():
    sim = Simulation(seed=0)
    sim.services.start()
    daa = sim.services.daa.daa
    assert daa.params.resolution_axes == ("hdg", "vs", "gs")
    sim.stack("DAA RESOAXES vs, hdg")
    assert daa.params.resolution_axes == ("vs", "hdg")
    for line in ("DAA RESOAXES HDG ALT", "DAA RESOAXES GS GS", "DAA VSMAX fast"):
        assert not sim.stack(line), line
    assert daa.params.resolution_axes == ("vs", "hdg")  # unchanged by the rejected lines
    errors = [m.text for m in sim.reporter.errors()]
    assert "unknown DAA resolution axis 'ALT'; known: HDG, VS, GS" in errors[0]
    assert "GS is given twice" in errors[1] and "VSMAX: 'fast' is not a number" in errors[2]
    sim.stack("DAA VSMAX 500")
    assert daa.params.vs_max_mps == pytest.approx(500 * 0.3048 / 60)
