"""DAIDALUS-style resolution bands: the ownship speeds, vertical speeds and headings that lose well clear.

For one ownship, a *conflict band* is a range of one manoeuvre variable
(ground speed along the current track, vertical speed, or heading at the
current ground speed) over which the ownship, changing that variable now and
flying straight, loses well clear with an intruder (flying straight) within
the look-ahead. Bands of several intruders are united per ownship; the
conflict-free bands are the rest of the aircraft's range. These are DAIDALUS's
"instantaneous" bands (Muñoz et al., DASC 2015), computed here from the
definitions in :mod:`aamsim.conflicts.wellclear`.

Ground-speed and vertical-speed band edges are exact: as a function of the
ground speed ``g`` the relative velocity is ``g e - w`` (``e`` the track's unit
vector, ``w`` the intruder's velocity), and whether a pair loses well clear
within ``[A, B]`` (the look-ahead cut by the vertical interval) can change only
where the state at ``A`` or ``B`` lies on the boundary of the DMOD circle or of
the modified-tau region, where ``d_cpa`` equals HMD or DMOD, where the tau
region appears (``d_cpa^2 = DMOD^2 + TAUMOD^2 |v|^2 / 4``, a quartic in ``g``), or
where the relative velocity vanishes. Those are roots of polynomials of degree
at most 4; between consecutive roots the answer is constant and is taken at the
midpoint. Vertical speed only moves the vertical interval, whose ends are linear
in it. Heading bands are sampled on a grid (``step_deg``, DAIDALUS's track step)
and their edges refined by bisection.
"""

from __future__ import annotations

import math

import numpy as np

from aamsim.conflicts.pairs import relative_state
from aamsim.conflicts.wellclear import horizontal_interval, vertical_interval, violation_interval
from aamsim.numba_cache import njit

MAX_EDGES = 32  # critical points per pair and variable (ground speed: at most 2 + 4 * 2 + 2 + 2 + 4 + 1)
MAX_BANDS = MAX_EDGES // 2 + 1


@njit(cache=True, inline="always")
def _push(out: np.ndarray, n: int, x: float, lo: float, hi: float) -> int:
    if lo < x < hi and n < out.shape[0]:
        out[n] = x
        return n + 1
    return n


@njit(cache=True)
def _quadratic_roots(a: float, b: float, c: float, out: np.ndarray, n: int, lo: float, hi: float) -> int:
    """Append the real roots of a x^2 + b x + c inside (lo, hi)."""
    scale = max(abs(a), abs(b), abs(c))
    if scale == 0.0:
        return n
    if abs(a) <= 1e-12 * scale:
        if abs(b) > 1e-12 * scale:
            n = _push(out, n, -c / b, lo, hi)
        return n
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        if disc > -1e-9 * b * b:  # a double root lost to rounding
            n = _push(out, n, -b / (2.0 * a), lo, hi)
        return n
    sq = math.sqrt(disc)
    q = -0.5 * (b + math.copysign(sq, b))  # the stable form
    n = _push(out, n, q / a, lo, hi)
    if q != 0.0:
        n = _push(out, n, c / q, lo, hi)
    return n


@njit(cache=True)
def _quartic_roots(c4: float, c3: float, c2: float, c1: float, c0: float, out: np.ndarray, n: int, lo: float,
                   hi: float) -> int:
    """Append the real roots of a quartic inside (lo, hi) (companion-matrix eigenvalues)."""
    scale = max(abs(c4), abs(c3), abs(c2), abs(c1), abs(c0))
    if scale == 0.0:
        return n
    if abs(c4) <= 1e-12 * scale and abs(c3) <= 1e-12 * scale:
        return _quadratic_roots(c2, c1, c0, out, n, lo, hi)
    coeffs = np.array([c4, c3, c2, c1, c0], dtype=np.complex128)
    k = 0
    while abs(coeffs[k].real) <= 1e-12 * scale:
        k += 1
    roots = np.roots(coeffs[k:])
    for r in roots:
        if abs(r.imag) <= 1e-7 * max(1.0, abs(r.real)):
            n = _push(out, n, r.real, lo, hi)
    return n


@njit(cache=True)
def _conflict_in(sx: float, sy: float, vx: float, vy: float, a: float, b: float, dmod: float, hmd: float,
                 taumod: float) -> bool:
    hlo, hhi = horizontal_interval(sx, sy, vx, vy, dmod, hmd, taumod)
    return max(hlo, a) <= min(hhi, b)


@njit(cache=True)
def _midpoints(edges: np.ndarray) -> np.ndarray:
    """Midpoints of the segments between sorted edges (one point when the range is a single value)."""
    if edges[-1] <= edges[0]:
        return edges[:1].copy()
    return 0.5 * (edges[:-1] + edges[1:])


@njit(cache=True)
def _collect(edges: np.ndarray, conf: np.ndarray, out: np.ndarray) -> int:
    """Bands (rows of ``out``) from the segments between ``edges`` whose midpoint is in conflict."""
    if edges[-1] <= edges[0]:
        if conf[0]:
            out[0, 0], out[0, 1] = edges[0], edges[-1]
            return 1
        return 0
    m = 0
    for k in range(edges.shape[0] - 1):
        g0, g1 = edges[k], edges[k + 1]
        if g1 <= g0 or not conf[k]:
            continue
        if m > 0 and out[m - 1, 1] >= g0:
            out[m - 1, 1] = g1
        elif m < out.shape[0]:
            out[m, 0], out[m, 1] = g0, g1
            m += 1
    return m


@njit(cache=True)
def gs_conflicts(sx: float, sy: float, sz: float, ex: float, ey: float, wx: float, wy: float, vz: float,
                 gmin: float, gmax: float, dmod: float, hmd: float, taumod: float, zthr: float, tcoa: float,
                 lookahead: float, out: np.ndarray) -> int:
    """Conflict bands of one pair over the ownship's ground speed ``g`` in ``[gmin, gmax]`` [m/s].

    ``s`` is the ownship's position relative to the intruder [m], ``e`` the ownship's
    unit track vector, ``w`` the intruder's horizontal velocity [m/s], ``vz`` the
    relative vertical speed [m/s] (the manoeuvre keeps it). Writes ``(lo, hi)`` rows
    into ``out`` (``MAX_BANDS x 2``) and returns how many.
    """
    zlo, zhi = vertical_interval(sz, vz, zthr, tcoa)
    a, b = max(zlo, 0.0), min(zhi, lookahead)
    if a > b or gmin > gmax:
        return 0
    pts = np.empty(MAX_EDGES)
    pts[0] = gmin
    n = 1
    ew = ex * wx + ey * wy
    ww = wx * wx + wy * wy
    sxe = sx * ey - sy * ex  # s x e
    sxw = sx * wy - sy * wx  # s x w
    for t in (a, b):
        # s + t v(g) = p + t g e with p = s - t w.
        px, py = sx - t * wx, sy - t * wy
        pe, pp, pw = px * ex + py * ey, px * px + py * py, px * wx + py * wy
        n = _quadratic_roots(t * t, 2.0 * t * pe, pp - dmod * dmod, pts, n, gmin, gmax)  # |s_t| = DMOD
        if taumod > 0.0:  # |s_t|^2 + TAUMOD s_t . v = DMOD^2
            n = _quadratic_roots(t * t + taumod * t, 2.0 * t * pe + taumod * pe - taumod * t * ew,
                                 pp - taumod * pw - dmod * dmod, pts, n, gmin, gmax)
    # d_cpa^2 |v|^2 = (s x v)^2 with s x v = g (s x e) - s x w and |v|^2 = g^2 - 2 g e.w + |w|^2.
    for d in (hmd, dmod):
        n = _quadratic_roots(sxe * sxe - d * d, -2.0 * sxe * sxw + 2.0 * d * d * ew, sxw * sxw - d * d * ww, pts, n,
                             gmin, gmax)
    if taumod > 0.0:  # (s x v)^2 - DMOD^2 |v|^2 - TAUMOD^2 |v|^4 / 4 = 0
        k = 0.25 * taumod * taumod
        d2 = dmod * dmod
        n = _quartic_roots(-k, 4.0 * k * ew, sxe * sxe - d2 - k * (4.0 * ew * ew + 2.0 * ww),
                           -2.0 * sxe * sxw + 2.0 * d2 * ew + 4.0 * k * ew * ww, sxw * sxw - d2 * ww - k * ww * ww,
                           pts, n, gmin, gmax)
    n = _push(pts, n, ew, gmin, gmax)  # where the relative velocity is smallest (zero if w is along e)
    if n < pts.shape[0]:
        pts[n] = gmax
        n += 1
    edges = np.sort(pts[:n])
    mids = _midpoints(edges)
    conf = np.empty(mids.shape[0], dtype=np.bool_)
    for k in range(mids.shape[0]):
        g = mids[k]
        conf[k] = _conflict_in(sx, sy, g * ex - wx, g * ey - wy, a, b, dmod, hmd, taumod)
    return _collect(edges, conf, out)


@njit(cache=True)
def vs_conflicts(sx: float, sy: float, sz: float, vx: float, vy: float, wz: float, vsmin: float, vsmax: float,
                 dmod: float, hmd: float, taumod: float, zthr: float, tcoa: float, lookahead: float,
                 out: np.ndarray) -> int:
    """Conflict bands of one pair over the ownship's vertical speed in ``[vsmin, vsmax]`` [m/s].

    ``v`` is the relative horizontal velocity (kept), ``wz`` the intruder's vertical speed.
    """
    hlo, hhi = horizontal_interval(sx, sy, vx, vy, dmod, hmd, taumod)
    a, b = max(hlo, 0.0), min(hhi, lookahead)
    if a > b or vsmin > vsmax:
        return 0
    pts = np.empty(MAX_EDGES)
    pts[0] = vsmin
    n = 1
    for t in (a, b):
        if t > 0.0:  # |s_z + t v_z| = ZTHR
            n = _push(pts, n, (zthr - sz) / t + wz, vsmin, vsmax)
            n = _push(pts, n, (-zthr - sz) / t + wz, vsmin, vsmax)
        if tcoa > 0.0 and t + tcoa > 0.0:  # t_coa(t) = TCOA
            n = _push(pts, n, -sz / (t + tcoa) + wz, vsmin, vsmax)
    n = _push(pts, n, wz, vsmin, vsmax)
    pts[n] = vsmax
    n += 1
    edges = np.sort(pts[:n])
    mids = _midpoints(edges)
    conf = np.empty(mids.shape[0], dtype=np.bool_)
    for k in range(mids.shape[0]):
        zlo, zhi = vertical_interval(sz, mids[k] - wz, zthr, tcoa)
        conf[k] = max(zlo, a) <= min(zhi, b)
    return _collect(edges, conf, out)


@njit(cache=True)
def _hdg_conflict(sx: float, sy: float, sz: float, gs: float, hdg: float, wx: float, wy: float, vz: float,
                  dmod: float, hmd: float, taumod: float, zthr: float, tcoa: float, lookahead: float) -> bool:
    h = math.radians(hdg)
    zlo, zhi = vertical_interval(sz, vz, zthr, tcoa)
    a, b = max(zlo, 0.0), min(zhi, lookahead)
    if a > b:
        return False
    return _conflict_in(sx, sy, gs * math.sin(h) - wx, gs * math.cos(h) - wy, a, b, dmod, hmd, taumod)


@njit(cache=True)
def hdg_conflicts(sx: float, sy: float, sz: float, gs: float, wx: float, wy: float, vz: float, step_deg: float,
                  dmod: float, hmd: float, taumod: float, zthr: float, tcoa: float, lookahead: float,
                  out: np.ndarray) -> int:
    """Conflict bands of one pair over the ownship's heading in ``[0, 360)`` [deg] at ground speed ``gs``.

    Sampled every ``step_deg``; each change between samples is refined by bisection
    to 1e-6 deg. A band crossing north is returned as two rows (``..., 360`` and ``0, ...``).
    """
    nstep = max(math.ceil(360.0 / step_deg), 4)
    h = 360.0 / nstep
    m = 0
    prev = _hdg_conflict(sx, sy, sz, gs, 0.0, wx, wy, vz, dmod, hmd, taumod, zthr, tcoa, lookahead)
    start = 0.0 if prev else -1.0
    for k in range(1, nstep + 1):
        x1 = k * h
        cur = _hdg_conflict(sx, sy, sz, gs, x1 % 360.0, wx, wy, vz, dmod, hmd, taumod, zthr, tcoa, lookahead)
        if cur != prev:
            lo, hi = x1 - h, x1
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                if _hdg_conflict(sx, sy, sz, gs, mid, wx, wy, vz, dmod, hmd, taumod, zthr, tcoa,
                                 lookahead) == prev:
                    lo = mid
                else:
                    hi = mid
            edge = 0.5 * (lo + hi)
            if cur:
                start = edge
            elif m < out.shape[0]:
                out[m, 0], out[m, 1] = start, edge
                m += 1
            prev = cur
    if prev and m < out.shape[0]:
        out[m, 0], out[m, 1] = start, 360.0
        m += 1
    return m


@njit(cache=True)
def merge_bands(owner: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unite the conflict bands of each owner: (owner, lo, hi) rows sorted by owner then ``lo``, disjoint."""
    order = np.argsort(lo, kind="mergesort")
    order = order[np.argsort(owner[order], kind="mergesort")]
    r_owner = np.empty(lo.shape[0], dtype=np.int64)
    r_lo = np.empty(lo.shape[0])
    r_hi = np.empty(lo.shape[0])
    m = 0
    for idx in order:
        o = owner[idx]
        if m > 0 and r_owner[m - 1] == o and lo[idx] <= r_hi[m - 1]:
            r_hi[m - 1] = max(r_hi[m - 1], hi[idx])
        else:
            r_owner[m], r_lo[m], r_hi[m] = o, lo[idx], hi[idx]
            m += 1
    return r_owner[:m], r_lo[:m], r_hi[:m]


@njit(cache=True)
def pair_gs_bands(latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray, sh: np.ndarray, alt: np.ndarray, u: np.ndarray,
                  v: np.ndarray, w: np.ndarray, ex: np.ndarray, ey: np.ndarray, own: np.ndarray, intr: np.ndarray,
                  gmin: np.ndarray, gmax: np.ndarray,
                  dmod: float, hmd: float, taumod: float, zthr: float, tcoa: float,
                  lookahead: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ground-speed conflict bands of directed pairs (ownship ``own[k]``, intruder ``intr[k]``), united per ownship.

    Aircraft positions come from the pair frame (:func:`aamsim.conflicts.pairs.pair_frame`),
    velocities ``u`` (east), ``v`` (north), ``w`` (up) [m/s], the unit vectors of the tracks
    ``ex``, ``ey`` (the heading when hovering); ``gmin``/``gmax`` per aircraft
    [m/s]. Returns rows (ownship slot, lo, hi) [m/s].
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
        cnt = gs_conflicts(-dx, -dy, -dz, ex[i], ey[i], u[j], v[j], -dw, gmin[i], gmax[i], dmod, hmd, taumod, zthr, tcoa,
                           lookahead, buf)
        for q in range(cnt):
            b_owner[nb], b_lo[nb], b_hi[nb] = i, buf[q, 0], buf[q, 1]
            nb += 1
    return merge_bands(b_owner[:nb], b_lo[:nb], b_hi[:nb])


@njit(cache=True)
def pair_exit_times(latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray, sh: np.ndarray, alt: np.ndarray,
                    u: np.ndarray, v: np.ndarray, w: np.ndarray, ex: np.ndarray, ey: np.ndarray, own: np.ndarray,
                    intr: np.ndarray, speeds: np.ndarray, dmod: float, hmd: float, taumod: float, zthr: float,
                    tcoa: float, lookahead: float) -> np.ndarray:
    """For directed pairs and candidate ground speeds of the ownship, when well clear is regained.

    Returns ``(pairs, speeds)``: the end of the violation interval that starts within
    ``lookahead`` [s from now], 0 when the pair stays well clear, ``inf`` when it never
    ends (no relative motion). DAIDALUS's recovery bands prefer the speeds that
    regain well clear soonest.
    """
    m = own.shape[0]
    out = np.zeros((m, speeds.shape[0]))
    for k in range(m):
        i, j = own[k], intr[k]
        dx, dy, dz, _du, _dv, dw = relative_state(latr, lonr, ch, sh, alt, u, v, w, i, j)
        for q in range(speeds.shape[0]):
            g = speeds[q]
            lo, hi = violation_interval(-dx, -dy, -dz, g * ex[i] - u[j], g * ey[i] - v[j], -dw, dmod, hmd, taumod,
                                        zthr, tcoa, 0.0, math.inf)
            if lo <= hi and lo <= lookahead:
                out[k, q] = hi
    return out
