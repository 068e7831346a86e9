"""RESO MVP never makes a state non-finite (issue 26 item 9a).

BlueSky 1.1.1's MVP divides by the time to CPA and by the horizontal distance:
two aircraft with the same track and speed have a time to CPA of exactly 0
(their relative speed is floored at 1e-3 m/s by the detection), and two at one
spot a distance of 0, so BlueSky flies both into NaN (checked: ``CRE A EC35
32.4 -141.1 0 1500 120`` and ``CRE B`` 550 m north of it, ``ASAS ON``, ``RESO
MVP``: both are NaN after one second in BlueSky). aamsim resolves such pairs
with finite pushes (:func:`aamsim.resolution.mvp._mvp_degenerate`); every
finite BlueSky push is kept as it is (the conformance scenarios and
tests/test_mvp_resolution.py check that).
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.resolution.mvp import (
    DEGENERATE_TIME_S,
    MVPSettings,
    OwnState,
    PairGeometry,
    combine,
    commands,
    mvp_pairs,
)

RPZ, HPZ, DTLOOK = 5 * 1852.0 * 1.05, 1000 * 0.3048 * 1.05, 300.0  # BlueSky's default zone, resolution factors

# Values where MVP's divisions degenerate, mixed with ordinary ones.
_tiny = st.sampled_from([0.0, -0.0, 5e-324, -5e-324, 1e-300, 1e-9, -1e-9])
position = st.one_of(_tiny, st.sampled_from([10.0, -10.0, 550.0, 9.9]), st.floats(-2e7, 2e7))
speed = st.one_of(_tiny, st.floats(-400.0, 400.0))
time_s = st.one_of(_tiny, st.sampled_from([1.0, -1.0, 1e8, -1e8]), st.floats(-1e17, 1e17))


def geometry(pairs: list[tuple[tuple[float, ...], tuple[float, ...], float, float]]) -> PairGeometry:
    m = len(pairs)
    own = np.array([k % 2 for k in range(m)], dtype=np.int64)
    return PairGeometry(own, 1 - own, np.array([p[0] for p in pairs], dtype=float).reshape(m, 3),
                        np.array([p[1] for p in pairs], dtype=float).reshape(m, 3),
                        np.array([p[2] for p in pairs], dtype=float), np.array([p[3] for p in pairs], dtype=float))


pair = st.tuples(st.tuples(position, position, position), st.tuples(speed, speed, speed), time_s, time_s)


@settings(max_examples=400, deadline=None)
@given(st.lists(pair, min_size=1, max_size=6), st.floats(1.0, 2e4), st.floats(1.0, 2e3), st.floats(1.0, 1e4),
       st.sampled_from(["BOTH", "SPD", "HDG", "V/S", "NONE"]))
@example([((0.0, 550.0, 0.0), (0.0, 0.0, 0.0), 0.0, -10.0)], RPZ, HPZ, DTLOOK, "BOTH")  # the issue's pair
@example([((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 0.0)], RPZ, HPZ, DTLOOK, "NONE")  # one spot, same velocity
@example([((0.0, 0.0, 0.0), (30.0, -5.0, 0.0), 0.0, -3.0)], RPZ, HPZ, DTLOOK, "BOTH")  # one spot, moving apart
@example([((300.0, 0.0, 0.0), (0.0, 0.0, 2.0), 0.0, 0.0)], RPZ, HPZ, DTLOOK, "V/S")  # co-altitude now
def test_pushes_and_commands_are_finite_for_any_finite_geometry(pairs, rpz, hpz, dtlook, method):
    g = geometry(pairs)
    push, tsol = mvp_pairs(g, rpz, hpz, dtlook)
    assert np.isfinite(push).all() and np.isfinite(tsol).all()
    mvp = MVPSettings()
    if method in ("BOTH", "SPD", "HDG", "NONE"):
        mvp.set_horizontal(method)
    else:
        mvp.set_vertical(method)
    none = np.zeros(2, dtype=bool)
    dv, tsolv = combine(2, g, push, tsol, mvp, np.zeros(2), none, none)
    assert np.isfinite(dv).all()
    s = OwnState(gseast=np.array([0.0, 30.0]), gsnorth=np.array([61.7, -10.0]), vs=np.zeros(2),
                 trk=np.array([0.0, 108.4]), gs=np.array([61.7, 31.6]), alt=np.array([457.2, 457.2]),
                 selalt=np.array([457.2, 457.2]), ap_vs=np.zeros(2), vmin=np.zeros(2), vmax=np.full(2, 72.0),
                 vsmin=np.full(2, -10.0), vsmax=np.full(2, 10.0))
    for value in commands(s, dv, tsolv, mvp, dtlook):
        assert np.isfinite(value).all()


def test_same_velocity_pair_is_pushed_apart_over_one_cycle():
    # The issue's pair seen from A: B 550 m north, same track and speed, so tCPA = 0. BlueSky's
    # push is 0 * 0 / 0 east (NaN) and 9,173 * 550 / 0 north (inf); here the intrusion
    # (9,723 - 550 m) over DEGENERATE_TIME_S along the line to B: straight north, 9,173 m/s,
    # then capped to the envelope by the commands.
    push, _ = mvp_pairs(geometry([((0.0, 550.0, 0.0), (0.0, 0.0, 0.0), 0.0, -10.0)]), RPZ, HPZ, DTLOOK)
    assert push[0, 0] == 0.0
    assert math.isclose(push[0, 1], (RPZ - 550.0) / DEGENERATE_TIME_S)


def test_a_pair_at_one_spot_is_pushed_sideways_of_its_relative_velocity_and_apart():
    # Same position, B flying east relative to A: sideways = perpendicular to the relative velocity.
    push, _ = mvp_pairs(geometry([((0.0, 0.0, 0.0), (20.0, 0.0, 0.0), 0.0, -5.0)]), RPZ, HPZ, DTLOOK)
    assert push[0, 0] == 0.0 and push[0, 1] != 0.0 and np.isfinite(push).all()
    # Same position and velocity: the two sides of the pair are pushed in opposite directions.
    both = geometry([((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, -5.0)] * 2)
    push, _ = mvp_pairs(both, RPZ, HPZ, DTLOOK)
    assert np.isfinite(push).all() and push[0, 0] == -push[1, 0] != 0.0


def test_finite_bluesky_pushes_are_unchanged():
    # A degenerate horizontal part does not change a finite vertical part (BlueSky's value is kept).
    push, tsol = mvp_pairs(geometry([((0.0, 550.0, 200.0), (0.0, 0.0, -4.0), 0.0, 2.0)]), 500.0, 300.0, 60.0)
    assert push[0, 2] == 300.0 / 50.0 and tsol[0] == 50.0


def run_pair(lines: str, seconds: float = 30.0) -> Simulation:
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.services.start()
    sim.stack("ASAS ON; RESO MVP")
    sim.stack(lines)
    sim.run_until(seconds)
    return sim


def finite_states(sim: Simulation) -> bool:
    v = sim.view
    return all(np.isfinite(np.asarray(x)).all() for x in (v.lat, v.lon, v.alt, v.trk, v.gs, v.tas, v.vs))


def test_the_issue_pair_stays_finite_in_a_simulation():
    # Two EC135s 550 m apart, same longitude, heading and speed at 32.4N 141.1W (issue 26 item 9):
    # before the fix both were deleted after one second with "state not finite".
    sim = run_pair("CRE A EC35 32.4 -141.1 0 1500 120; CRE B EC35 32.40495 -141.1 0 1500 120")
    assert [str(m) for m in sim.reporter.messages if m.kind == "error"] == []
    assert sim.view.n == 2 and finite_states(sim)


@settings(max_examples=25, deadline=None)
@given(lat=st.one_of(st.sampled_from([89.9999, -89.9999, 90.0, -90.0, 0.0, 32.4]), st.floats(-90.0, 90.0)),
       lon=st.one_of(st.sampled_from([-180.0, 179.9999]), st.floats(-180.0, 179.999)),
       north_m=st.one_of(st.just(0.0), st.floats(-600.0, 600.0)),
       east_m=st.one_of(st.just(0.0), st.floats(-600.0, 600.0)),
       hdg=st.floats(0.0, 359.0), hdg_b=st.one_of(st.none(), st.floats(0.0, 359.0)),
       spd=st.sampled_from([0.0, 60.0, 120.0]), spd_b=st.one_of(st.none(), st.sampled_from([0.0, 60.0, 120.0])),
       dalt_ft=st.sampled_from([0, 0, 300, -900]))
def test_degenerate_pairs_in_a_simulation_stay_finite(lat, lon, north_m, east_m, hdg, hdg_b, spd, spd_b, dalt_ft):
    """Coincident aircraft, the same track and speed (hdg_b/spd_b None), near and at the poles."""
    lat_b = min(max(lat + north_m / 111_195.0, -90.0), 90.0)
    coslat = max(math.cos(math.radians(lat)), 1e-6)
    lon_b = (lon + east_m / (111_195.0 * coslat) + 180.0) % 360.0 - 180.0
    hb = hdg if hdg_b is None else hdg_b
    sb = spd if spd_b is None else spd_b
    sim = run_pair(f"CRE A EC35 {lat!r} {lon!r} {hdg!r} 1500 {spd!r}; "
                   f"CRE B EC35 {lat_b!r} {lon_b!r} {hb!r} {1500 + dalt_ft} {sb!r}", seconds=10.0)
    assert [str(m) for m in sim.reporter.messages if "not finite" in str(m)] == []
    assert finite_states(sim)
