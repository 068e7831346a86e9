"""The DO-365 / DAIDALUS well-clear volume on straight-line encounters, compiled with Numba.

Written here from the published definitions (RTCA DO-365, Appendix on the
well-clear definition; Muñoz, Narkawicz, Hagen, Upchurch, Dutle, Consiglio,
Chamberlain, "DAIDALUS: Detect and Avoid Alerting Logic for Unmanned Systems",
DASC 2015; Muñoz, Narkawicz, Chamberlain, Consiglio, Upchurch, "A family of
well-clear boundary models for the integration of UAS in the NAS", AIAA
Aviation 2014). No code was copied.

Notation: ``s`` is the position of the ownship relative to the intruder, ``v``
the relative velocity (ownship minus intruder), horizontal parts ``s_h``,
``v_h``, vertical ``s_z``, ``v_z``. A pair violates well clear when both

* horizontally: ``|s_h| <= DMOD``, or the projected horizontal miss distance
  ``d_cpa <= HMD`` and the modified tau ``0 <= tau_mod <= TAUMOD``, where
  ``tau_mod = (DMOD^2 - |s_h|^2) / (s_h . v_h)`` while closing (``s_h . v_h < 0``);
* vertically: ``|s_z| <= ZTHR``, or the time to co-altitude
  ``0 <= t_coa = -s_z / v_z <= TCOA`` while closing (``s_z v_z < 0``).

Flying straight, each condition holds on one interval of time (derived in
:func:`horizontal_interval`), so a loss of well clear within a look-ahead is
the intersection of two intervals with ``[0, T]``: no sampling in time.
"""

from __future__ import annotations

import math

import numpy as np

from aamsim.conflicts.pairs import relative_state
from aamsim.numba_cache import njit

# A relative speed below this [m/s] is no relative motion (the state then never changes).
_STILL = 1e-9


@njit(cache=True, inline="always")
def _empty() -> tuple[float, float]:
    return math.inf, -math.inf


@njit(cache=True)
def horizontal_interval(sx: float, sy: float, vx: float, vy: float, dmod: float, hmd: float,
                        taumod: float) -> tuple[float, float]:
    """Times [s from now] during which the pair violates the horizontal well-clear condition.

    The DMOD circle is entered and left at ``t_cpa -+ sqrt((DMOD^2 - d_cpa^2) / |v|^2)``.
    The tau condition, multiplied out by the negative ``s(t) . v``, is the quadratic
    ``|v|^2 t^2 + (2 s.v + TAUMOD |v|^2) t + |s|^2 + TAUMOD s.v - DMOD^2 <= 0`` for
    ``t < t_cpa`` (closing); its roots are real iff ``d_cpa^2 <= DMOD^2 + TAUMOD^2 |v|^2 / 4``.
    When the circle is entered, its entry time satisfies the quadratic, so the two
    sets join into one interval. Returns ``(t_in, t_out)``; empty when ``t_in > t_out``;
    infinite ends when the pair does not move relative to each other.
    """
    v2 = vx * vx + vy * vy
    s2 = sx * sx + sy * sy
    if v2 < _STILL:
        return (-math.inf, math.inf) if s2 <= dmod * dmod else _empty()
    sv = sx * vx + sy * vy
    tcpa = -sv / v2
    dcpa2 = max(s2 - sv * sv / v2, 0.0)
    lo, hi = _empty()
    if dcpa2 <= dmod * dmod:
        half = math.sqrt((dmod * dmod - dcpa2) / v2)
        lo, hi = tcpa - half, tcpa + half
    if taumod > 0.0 and dcpa2 <= hmd * hmd:
        b = 2.0 * sv + taumod * v2
        c = s2 + taumod * sv - dmod * dmod
        disc = b * b - 4.0 * v2 * c
        if disc >= 0.0:
            sq = math.sqrt(disc)
            r1 = (-b - sq) / (2.0 * v2)
            r2 = min((-b + sq) / (2.0 * v2), tcpa)
            if r1 <= r2:
                lo, hi = min(lo, r1), max(hi, r2)
    return lo, hi


@njit(cache=True)
def vertical_interval(sz: float, vz: float, zthr: float, tcoa: float) -> tuple[float, float]:
    """Times [s from now] during which the pair violates the vertical well-clear condition.

    ``|s_z(t)| <= ZTHR`` between the two crossings of ``+-ZTHR``; the co-altitude
    condition adds ``[t_coa - TCOA, t_coa]``, which ends inside the first set.
    """
    if abs(vz) < _STILL:
        return (-math.inf, math.inf) if abs(sz) <= zthr else _empty()
    t1 = (-zthr - sz) / vz
    t2 = (zthr - sz) / vz
    lo, hi = min(t1, t2), max(t1, t2)
    if tcoa > 0.0:
        lo = min(lo, -sz / vz - tcoa)
    return lo, hi


@njit(cache=True)
def violation_interval(sx: float, sy: float, sz: float, vx: float, vy: float, vz: float, dmod: float, hmd: float,
                       taumod: float, zthr: float, tcoa: float, t0: float, t1: float) -> tuple[float, float]:
    """Part of ``[t0, t1]`` [s from now] in which the pair is not well clear (empty when ``t_in > t_out``)."""
    hlo, hhi = horizontal_interval(sx, sy, vx, vy, dmod, hmd, taumod)
    if hlo > hhi:
        return _empty()
    zlo, zhi = vertical_interval(sz, vz, zthr, tcoa)
    return max(hlo, zlo, t0), min(hhi, zhi, t1)


@njit(cache=True)
def in_violation(sx: float, sy: float, sz: float, vx: float, vy: float, vz: float, dmod: float, hmd: float,
                 taumod: float, zthr: float, tcoa: float) -> bool:
    """The well-clear predicate on one state, written directly from the definition (no intervals).

    Used by the tests as the independent reference for the interval algebra.
    """
    s2 = sx * sx + sy * sy
    horizontal = s2 <= dmod * dmod
    sv = sx * vx + sy * vy
    v2 = vx * vx + vy * vy
    if not horizontal and sv < 0.0 and v2 > _STILL:
        dcpa2 = max(s2 - sv * sv / v2, 0.0)
        tau = (dmod * dmod - s2) / sv
        horizontal = dcpa2 <= hmd * hmd and 0.0 <= tau <= taumod
    vertical = abs(sz) <= zthr
    if not vertical and sz * vz < 0.0:
        vertical = -sz / vz <= tcoa
    return horizontal and vertical


@njit(cache=True)
def pair_alerts(latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray, sh: np.ndarray, alt: np.ndarray, u: np.ndarray,
                v: np.ndarray, w: np.ndarray, pi: np.ndarray, pj: np.ndarray, volumes: np.ndarray,
                alerting_s: np.ndarray, lookahead: float) -> tuple[np.ndarray, np.ndarray]:
    """Alert level of each pair and its time to loss of well clear under each level's volume.

    ``volumes`` has one row per alert level, lowest first: DMOD, HMD, TAUMOD, ZTHR, TCOA
    [m, m, s, m, s]; ``alerting_s`` the level's alerting time [s]. A pair is at level
    ``k + 1`` when it loses well clear under volume ``k`` within ``alerting_s[k]``; its
    level is the highest such. Returns levels (0: none) and ``t_in`` (pairs x levels,
    ``inf`` when well clear over ``lookahead``).
    """
    m = pi.shape[0]
    nl = volumes.shape[0]
    level = np.zeros(m, dtype=np.int64)
    t_in = np.full((m, nl), np.inf)
    for k in range(m):
        dx, dy, dz, du, dv, dw = relative_state(latr, lonr, ch, sh, alt, u, v, w, pi[k], pj[k])
        for q in range(nl):
            a, b = violation_interval(dx, dy, dz, du, dv, dw, volumes[q, 0], volumes[q, 1], volumes[q, 2],
                                      volumes[q, 3], volumes[q, 4], 0.0, lookahead)
            if a <= b:
                t_in[k, q] = a
                if a <= alerting_s[q]:
                    level[k] = q + 1
    return level, t_in
