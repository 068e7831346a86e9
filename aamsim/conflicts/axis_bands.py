"""Heading and vertical-speed conflict bands of aircraft pairs, and well-clear checks of candidate velocities.

:mod:`aamsim.conflicts.bands` computes the bands of one pair for each manoeuvre
variable; here they are computed for many directed pairs (ownship, intruder)
at once and united per ownship, as :func:`aamsim.conflicts.bands.pair_gs_bands`
does for ground speed:

* :func:`pair_hdg_bands`: the tracks [deg] that, flown now at the ownship's
  ground speed, lose well clear within the look-ahead (sampled every
  ``step_deg``, edges bisected);
* :func:`pair_vs_bands`: the vertical speeds [m/s] that do, horizontal motion kept
  (exact edges);
* :func:`velocity_intervals`: for any candidate velocity of an ownship (a turn,
  a climb, a speed change or several at once), when it would lose well clear
  with each intruder and when it would regain it. The DAA resolutions use it
  for the recovery manoeuvres (DAIDALUS's recovery bands: regain well clear
  soonest without entering the recovery volume) and to check a resumption
  (back on the route, back to the own altitude) before it is made.

Positions come from the pair frame (:func:`aamsim.conflicts.pairs.pair_frame`),
velocities ``u`` (east), ``v`` (north), ``w`` (up) [m/s].
"""

from __future__ import annotations

import numpy as np

from aamsim.conflicts.bands import MAX_BANDS, hdg_conflicts, merge_bands, vs_conflicts
from aamsim.conflicts.pairs import relative_state
from aamsim.conflicts.wellclear import in_violation, violation_interval
from aamsim.numba_cache import njit


@njit(cache=True)
def pair_hdg_bands(latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray, sh: np.ndarray, alt: np.ndarray,
                   u: np.ndarray, v: np.ndarray, w: np.ndarray, gs: np.ndarray, own: np.ndarray, intr: np.ndarray,
                   step_deg: float, dmod: float, hmd: float, taumod: float, zthr: float, tcoa: float,
                   lookahead: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Track conflict bands [deg, 0..360] of directed pairs, united per ownship: rows (ownship slot, lo, hi).

    ``gs`` is each aircraft's ground speed for the turn [m/s]; a band across north
    comes as two rows (``lo..360`` and ``0..hi``).
    """
    m = own.shape[0]
    b_owner = np.empty(m * MAX_BANDS, dtype=np.int64)
    b_lo = np.empty(m * MAX_BANDS)
    b_hi = np.empty(m * MAX_BANDS)
    buf = np.empty((MAX_BANDS, 2))
    nb = 0
    for k in range(m):
        i, j = own[k], intr[k]
        dx, dy, dz, _du, _dv, dw = relative_state(latr, lonr, ch, sh, alt, u, v, w, i, j)
        cnt = hdg_conflicts(-dx, -dy, -dz, gs[i], u[j], v[j], -dw, step_deg, dmod, hmd, taumod, zthr, tcoa,
                            lookahead, buf)
        for q in range(cnt):
            b_owner[nb], b_lo[nb], b_hi[nb] = i, buf[q, 0], buf[q, 1]
            nb += 1
    return merge_bands(b_owner[:nb], b_lo[:nb], b_hi[:nb])


@njit(cache=True)
def pair_vs_bands(latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray, sh: np.ndarray, alt: np.ndarray,
                  u: np.ndarray, v: np.ndarray, w: np.ndarray, own: np.ndarray, intr: np.ndarray, vsmin: np.ndarray,
                  vsmax: np.ndarray, dmod: float, hmd: float, taumod: float, zthr: float, tcoa: float,
                  lookahead: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertical-speed conflict bands [m/s] of directed pairs within ``[vsmin, vsmax]`` of each ownship, united."""
    m = own.shape[0]
    b_owner = np.empty(m * MAX_BANDS, dtype=np.int64)
    b_lo = np.empty(m * MAX_BANDS)
    b_hi = np.empty(m * MAX_BANDS)
    buf = np.empty((MAX_BANDS, 2))
    nb = 0
    for k in range(m):
        i, j = own[k], intr[k]
        dx, dy, dz, du, dv, _dw = relative_state(latr, lonr, ch, sh, alt, u, v, w, i, j)
        cnt = vs_conflicts(-dx, -dy, -dz, -du, -dv, w[j], vsmin[i], vsmax[i], dmod, hmd, taumod, zthr, tcoa,
                           lookahead, buf)
        for q in range(cnt):
            b_owner[nb], b_lo[nb], b_hi[nb] = i, buf[q, 0], buf[q, 1]
            nb += 1
    return merge_bands(b_owner[:nb], b_lo[:nb], b_hi[:nb])


@njit(cache=True)
def velocity_intervals(latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray, sh: np.ndarray, alt: np.ndarray,
                       u: np.ndarray, v: np.ndarray, w: np.ndarray, own: np.ndarray, intr: np.ndarray,
                       row: np.ndarray, cu: np.ndarray, cv: np.ndarray, cw: np.ndarray, dmod: float, hmd: float,
                       taumod: float, zthr: float, tcoa: float) -> tuple[np.ndarray, np.ndarray]:
    """Loss of well clear of candidate ownship velocities against straight-flying intruders.

    Pair ``k`` (ownship ``own[k]``, intruder ``intr[k]``) is checked for every candidate
    velocity of its ownship: row ``row[k]`` of ``cu``, ``cv``, ``cw`` (east, north, up
    [m/s]; rows x candidates). Returns ``t_in`` and ``t_out`` (pairs x candidates, [s
    from now]): the interval in which the pair is not well clear, ``t_in = inf`` when
    it never loses well clear from now on.
    """
    m = own.shape[0]
    nc = cu.shape[1]
    t_in = np.full((m, nc), np.inf)
    t_out = np.full((m, nc), -np.inf)
    for k in range(m):
        i, j, r = own[k], intr[k], row[k]
        dx, dy, dz, _du, _dv, _dw = relative_state(latr, lonr, ch, sh, alt, u, v, w, i, j)
        for q in range(nc):
            lo, hi = violation_interval(-dx, -dy, -dz, cu[r, q] - u[j], cv[r, q] - v[j], cw[r, q] - w[j], dmod, hmd,
                                        taumod, zthr, tcoa, 0.0, np.inf)
            if lo <= hi:
                t_in[k, q], t_out[k, q] = lo, hi
    return t_in, t_out


@njit(cache=True)
def manoeuvre_intervals(latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray, sh: np.ndarray, alt: np.ndarray,
                        u: np.ndarray, v: np.ndarray, w: np.ndarray, own: np.ndarray, intr: np.ndarray,
                        row: np.ndarray, trk_deg: np.ndarray, gs: np.ndarray, dalt: np.ndarray, rate: np.ndarray,
                        dmod: float, hmd: float, taumod: float, zthr: float, tcoa: float, lookahead: float,
                        step_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Loss of well clear of candidate manoeuvres that turn and change level, sampled in time.

    A candidate of row ``r`` (rows x candidates) turns at once to track ``trk_deg[r, q]``
    at ground speed ``gs[r, q]`` and changes altitude by ``dalt[r, q]`` [m] at ``rate[r, q]``
    [m/s], then flies level (DAIDALUS's kinematic altitude manoeuvres, here with an instant
    turn); intruders fly straight. The well-clear predicate is evaluated every
    ``step_s`` over ``[0, lookahead]``. Returns ``first`` and ``last`` (pairs x candidates):
    the first and last sampled time not well clear (``inf`` / ``-inf``: none).
    """
    m = own.shape[0]
    nc = trk_deg.shape[1]
    first = np.full((m, nc), np.inf)
    last = np.full((m, nc), -np.inf)
    nstep = int(lookahead / step_s) + 1
    for k in range(m):
        i, j, r = own[k], intr[k], row[k]
        dx, dy, dz, _du, _dv, _dw = relative_state(latr, lonr, ch, sh, alt, u, v, w, i, j)
        for q in range(nc):
            h = np.radians(trk_deg[r, q])
            ou, ov = gs[r, q] * np.sin(h), gs[r, q] * np.cos(h)
            climb = abs(dalt[r, q]) / rate[r, q] if rate[r, q] > 0.0 else 0.0
            vz = np.sign(dalt[r, q]) * rate[r, q]
            for n in range(nstep):
                t = n * step_s
                up = vz * min(t, climb)  # the ownship's altitude change by t
                sx, sy = -dx + t * (ou - u[j]), -dy + t * (ov - v[j])
                sz = -dz + up - t * w[j]
                wz = (vz if t < climb else 0.0) - w[j]
                if in_violation(sx, sy, sz, ou - u[j], ov - v[j], wz, dmod, hmd, taumod, zthr, tcoa):
                    first[k, q] = min(first[k, q], t)
                    last[k, q] = t
    return first, last
