"""DO-365 / DAIDALUS well-clear volume, alert levels and bands on hand-computed encounters.

Relative states are the ownship's position and velocity minus the intruder's
(x east, y north, z up; m and m/s). Thresholds unless said otherwise: DMOD = HMD
= 450 m, TAUMOD 35 s, ZTHR 137.16 m (450 ft), TCOA 0, look-ahead 75 s.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from aamsim.conflicts.bands import MAX_BANDS, gs_conflicts, hdg_conflicts, vs_conflicts
from aamsim.conflicts.wellclear import horizontal_interval, in_violation, violation_interval

D, H, TAU, Z, TCOA, T = 450.0, 450.0, 35.0, 137.16, 0.0, 75.0
VOL = (D, H, TAU, Z, TCOA)


def tau_entry_range(closing_mps: float, dmod: float = D, taumod: float = TAU) -> float:
    """Range at which a collision course (d_cpa = 0) reaches tau_mod = TAUMOD.

    tau_mod = (DMOD^2 - r^2) / (-r c) = TAUMOD  <=>  r^2 - TAUMOD c r - DMOD^2 = 0.
    """
    c = closing_mps
    return (taumod * c + math.sqrt((taumod * c) ** 2 + 4 * dmod**2)) / 2


def bands(fn, *args) -> list[tuple[float, float]]:
    out = np.zeros((MAX_BANDS, 2))
    n = fn(*args, out)
    return [tuple(r) for r in out[:n].tolist()]


# ---------------------------------------------------------------------------- encounters
def test_head_on_time_to_loss_of_well_clear_is_the_modified_tau_entry():
    # 5 km apart, each at 50 m/s: closing at 100 m/s, on a collision course.
    r = tau_entry_range(100.0)
    assert r == pytest.approx(3556.93, abs=0.01)
    t_in, t_out = violation_interval(0, -5000, 0, 0, 100, 0, *VOL, 0.0, T)
    assert t_in == pytest.approx((5000 - r) / 100)  # 14.43 s
    assert t_out == pytest.approx((5000 + 450) / 100)  # leaves the DMOD circle at 54.5 s
    # Without the tau term only the DMOD circle: entered at 45.5 s.
    assert violation_interval(0, -5000, 0, 0, 100, 0, D, H, 0.0, Z, TCOA, 0.0, T)[0] == pytest.approx(45.5)
    # At the entry, tau_mod equals TAUMOD; just before, the predicate says well clear.
    assert in_violation(0, -r, 0, 0, 100, 0, *VOL)
    assert not in_violation(0, -(r + 0.01), 0, 0, 100, 0, *VOL)


def test_head_on_on_the_next_layer_is_well_clear_and_vertical_speed_bands_are_exact():
    # 700 ft apart (the corridor layers): above ZTHR, never a loss of well clear level.
    t_in, t_out = violation_interval(0, -5000, -213.36, 0, 100, 0, *VOL, 0.0, T)
    assert t_in > t_out
    # Same layer: vertical speeds |vs| <= ZTHR / t_in keep |dz| <= ZTHR at the horizontal entry.
    t_h = (5000 - tau_entry_range(100.0)) / 100
    got = bands(vs_conflicts, 0, -5000, 0, 0, 100, 0.0, -15.0, 15.0, *VOL, T)
    assert got == [pytest.approx((-Z / t_h, Z / t_h))]  # +-9.505 m/s


def test_overtake_alerts_corrective_and_the_speed_band_edge_is_the_closed_form():
    # Ownship 2 km behind, 50 m/s against 30 m/s: closing at 20 m/s.
    t_in, _ = violation_interval(0, -2000, 0, 0, 20, 0, *VOL, 0.0, T)
    assert t_in == pytest.approx((2000 - tau_entry_range(20.0)) / 20)  # 54.0 s: corrective, not warning
    assert 25.0 < t_in <= 55.0
    # Ground speeds g lose well clear within 75 s when 75 c + r(c) >= 2000 with c = g - 30,
    # that is (4000 - 185 c)^2 = 1225 c^2 + 810000 -> 33000 c^2 - 1480000 c + 15190000 = 0.
    c = (1480000 - math.sqrt(1480000**2 - 4 * 33000 * 15190000)) / 66000
    got = bands(gs_conflicts, 0, -2000, 0, 0.0, 1.0, 0.0, 30.0, 0.0, 0.0, 72.0, *VOL, T)
    assert got == [pytest.approx((30 + c, 72.0))]  # 45.90 m/s and faster


def test_crossing_speed_band_is_where_the_miss_distance_is_dmod():
    # Ownship north at g from the origin, intruder west at 50 m/s from (3000, 3000): TAUMOD 0, so the
    # band is where d_cpa = |s x v| / |v| <= DMOD, with s x v = 3000 (50 - g), |v|^2 = 2500 + g^2.
    k = 9e6 / D**2
    a, b, cc = k - 1, -100 * k, 2500 * k - 2500
    g1, g2 = sorted((-b + sgn * math.sqrt(b * b - 4 * a * cc)) / (2 * a) for sgn in (-1, 1))
    got = bands(gs_conflicts, -3000, -3000, 0, 0.0, 1.0, -50.0, 0.0, 0.0, 0.0, 72.0, D, H, 0.0, Z, TCOA, T)
    assert got == [pytest.approx((g1, g2))]
    assert g1 < 50 < g2  # the planned 50 m/s collides
    # The same crossing at 50 m/s, with TAUMOD: a warning (inside 25 s).
    t_in, _ = violation_interval(-3000, -3000, 0, 50, 50, 0, *VOL, 0.0, T)
    assert t_in == pytest.approx((3000 * math.sqrt(2) - tau_entry_range(50 * math.sqrt(2))) / (50 * math.sqrt(2)))
    assert t_in < 25.0


def test_heading_bands_of_a_head_on_encounter_straddle_north():
    got = bands(hdg_conflicts, 0, -5000, 0, 50.0, 0.0, -50.0, 0.0, 1.0, *VOL, T)
    assert len(got) == 2 and got[0][0] == 0.0 and got[1][1] == 360.0
    assert 360.0 - got[1][0] == pytest.approx(got[0][1], abs=1e-6)  # symmetric about north
    for hdg, inside in ((got[0][1] - 0.01, True), (got[0][1] + 0.01, False)):
        h = math.radians(hdg)
        t_in, t_out = violation_interval(0, -5000, 0, 50 * math.sin(h), 50 * math.cos(h) + 50, 0, *VOL, 0.0, T)
        assert (t_in <= t_out) == inside


def test_time_to_co_altitude_extends_the_vertical_condition():
    # 300 m below, climbing towards the intruder at 5 m/s: co-altitude at 60 s, |dz| <= ZTHR from 32.6 s.
    assert violation_interval(0, 0, -300, 0, 0, 5, D, H, TAU, Z, 0.0, 0.0, T)[0] == pytest.approx((300 - Z) / 5)
    assert violation_interval(0, 0, -300, 0, 0, 5, D, H, TAU, Z, 40.0, 0.0, T)[0] == pytest.approx(60 - 40)


def test_still_pairs_and_diverging_pairs():
    assert horizontal_interval(100, 0, 0, 0, D, H, TAU) == (-math.inf, math.inf)
    assert violation_interval(1000, 0, 0, 0, 0, 0, *VOL, 0.0, T)[0] == math.inf
    # Moving apart at 600 m: nothing ahead (the DMOD circle was behind them).
    t_in, t_out = violation_interval(600, 0, 0, 10, 0, 0, *VOL, 0.0, T)
    assert t_in > t_out


# ---------------------------------------------------------------------------- properties
coord = st.floats(-6000, 6000)
speed = st.floats(0, 70)
angle = st.floats(0, 360)


@st.composite
def encounters(draw):
    sx, sy = draw(coord), draw(coord)
    sz = draw(st.floats(-300, 300))
    trk = math.radians(draw(angle))
    w_spd, w_trk = draw(speed), math.radians(draw(angle))
    vz = draw(st.floats(-5, 5))
    return sx, sy, sz, math.sin(trk), math.cos(trk), w_spd * math.sin(w_trk), w_spd * math.cos(w_trk), vz


@st.composite
def volumes(draw):
    """DMOD, HMD (also larger than DMOD, where the tau region's own boundary matters), TAUMOD, ZTHR, TCOA."""
    dmod = draw(st.floats(150, 600))
    return dmod, dmod * draw(st.floats(0.5, 2.0)), draw(st.floats(0, 40)), draw(st.floats(50, 200)), \
        draw(st.sampled_from([0.0, 10.0]))


def well_clear_along(sx, sy, sz, vx, vy, vz, vol, step=0.05) -> bool:
    """Sample the definition itself (no intervals) every ``step`` over the look-ahead.

    The distance thresholds are shrunk by one part in a billion: a pair exactly on the volume's
    edge and leaving it (hypothesis found an intruder exactly DMOD away at t = 0) touches the
    volume for an instant, which the bands rightly ignore and an exact comparison would not.
    """
    dmod, hmd, taumod, zthr, tcoa = vol
    shrunk = (dmod * (1 - 1e-9), hmd * (1 - 1e-9), taumod, zthr * (1 - 1e-9), tcoa)
    for t in np.arange(0.0, T + step / 2, step):
        if in_violation(sx + t * vx, sy + t * vy, sz + t * vz, vx, vy, vz, *shrunk):
            return False
    return True


@settings(max_examples=300, deadline=None)
@given(encounters(), volumes(), st.floats(0.02, 0.98))
# pairs on the volume's edge that hypothesis found: at DMOD and leaving it, at ZTHR and climbing away,
# and passing exactly DMOD abeam whatever the speed
@example((199.0, 0.0, 0.0, 0.01745240643728351, 0.9998476951563913, 0.0, 1.0, 0.0), (199.0, 199.0, 0.0, 50.0, 0.0),
         0.5)
@example((0.0, 0.0, 50.0, 0.0, 1.0, 0.0, 0.0, 1.0), (150.0, 150.0, 0.0, 50.0, 0.0), 0.5)
@example((150.0, -229.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0), (150.0, 150.0, 0.0, 50.0, 0.0), 0.125)
def test_a_speed_in_a_conflict_free_band_keeps_the_pair_well_clear(enc, vol, frac):
    sx, sy, sz, ex, ey, wx, wy, vz = enc
    conflict = bands(gs_conflicts, sx, sy, sz, ex, ey, wx, wy, vz, 0.0, 72.0, *vol, T)
    free, start = [], 0.0
    for lo, hi in conflict:
        if lo > start:
            free.append((start, lo))
        start = hi
    if start < 72.0:
        free.append((start, 72.0))
    # Bands narrower than 1 mm/s are left out: they come from a pair grazing the volume's edge
    # (hypothesis found an intruder exactly DMOD away, with a 6e-5 m/s band), where a sampled
    # point and the exact edge disagree by rounding, not by logic.
    for lo, hi in free:
        if hi - lo < 1e-3:
            continue
        g = lo + frac * (hi - lo)
        assert well_clear_along(sx, sy, sz, g * ex - wx, g * ey - wy, vz, vol), (g, free, conflict)
    for lo, hi in conflict:  # and a speed inside a conflict band loses well clear within the look-ahead
        if hi - lo < 1e-3:
            continue
        g = lo + frac * (hi - lo)
        vx, vy = g * ex - wx, g * ey - wy
        t_in, t_out = violation_interval(sx, sy, sz, vx, vy, vz, *vol, 0.0, T)
        if t_out - t_in < 1e-9:
            # Empty, or touching for an instant: only where every speed of the band grazes the volume's
            # edge (hypothesis found an intruder passing exactly DMOD abeam whatever the speed) ...
            d_cpa = abs(sx * vy - sy * vx) / math.hypot(vx, vy) if vx or vy else math.hypot(sx, sy)
            # ... or that is on the edge now and leaving it (horizontally at DMOD, or vertically at ZTHR)
            edges = [abs(d_cpa - vol[0]) / vol[0], abs(d_cpa - vol[1]) / vol[1],
                     abs(math.hypot(sx, sy) - vol[0]) / vol[0], abs(abs(sz) - vol[3]) / vol[3]]
            assert min(edges) < 1e-6, (g, conflict, t_in, t_out)
            continue
        t = 0.5 * (t_in + t_out)
        assert in_violation(sx + t * vx, sy + t * vy, sz + t * vz, vx, vy, vz, *vol)


@settings(max_examples=300, deadline=None)
@given(encounters(), volumes(), speed, st.floats(0, 75))
def test_the_violation_interval_is_where_the_definition_holds(enc, vol, g, t):
    sx, sy, sz, ex, ey, wx, wy, vz = enc
    vx, vy = g * ex - wx, g * ey - wy
    t_in, t_out = violation_interval(sx, sy, sz, vx, vy, vz, *vol, -math.inf, math.inf)
    inside = in_violation(sx + t * vx, sy + t * vy, sz + t * vz, vx, vy, vz, *vol)
    if min(abs(t - t_in), abs(t - t_out)) > 1e-6:
        assert inside == (t_in <= t <= t_out)
