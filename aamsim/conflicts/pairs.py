"""Exact pair tests, compiled with Numba: state-based conflict detection and
loss-of-separation volumes.

Relative positions use BlueSky's equirectangular ("kwik") formulas per pair:
intruder j relative to ownship i is ``dx = R dlon cos(mean lat)``, ``dy = R
dlat``, ``dz = alt_j - alt_i``; velocities are ground speed along track plus
vertical speed. All aircraft move in straight lines between checks.
"""

from __future__ import annotations

import math

import numpy as np

from aamsim.numba_cache import njit
from aamsim.units import R_EARTH


@njit(cache=True)
def pair_frame(lat: np.ndarray, lon: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-aircraft terms of the pair formulas, computed once per check instead of once per pair.

    Returns latitude and longitude in radians and the cosine and sine of half
    the latitude: cos((lat_i + lat_j) / 2) = ch_i ch_j - sh_i sh_j.
    """
    n = lat.shape[0]
    latr = np.empty(n)
    lonr = np.empty(n)
    ch = np.empty(n)
    sh = np.empty(n)
    for i in range(n):
        latr[i] = math.radians(lat[i])
        lonr[i] = math.radians(lon[i])
        ch[i] = math.cos(0.5 * latr[i])
        sh[i] = math.sin(0.5 * latr[i])
    return latr, lonr, ch, sh


@njit(cache=True, inline="always")
def relative_state(
    latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray, sh: np.ndarray, alt: np.ndarray, u: np.ndarray,
    v: np.ndarray, w: np.ndarray, i: int, j: int
) -> tuple[float, float, float, float, float, float]:
    """Position [m] and velocity [m/s] of j relative to i: dx, dy, dz, du, dv, dw.

    BlueSky's formulas, ``dx = R dlon cos(mean lat)``, from the :func:`pair_frame`
    terms: no trigonometry per pair.
    """
    dlon = lonr[j] - lonr[i]
    if dlon >= math.pi:
        dlon -= 2.0 * math.pi
    elif dlon < -math.pi:
        dlon += 2.0 * math.pi
    cavelat = ch[i] * ch[j] - sh[i] * sh[j]
    return (R_EARTH * dlon * cavelat, R_EARTH * (latr[j] - latr[i]), alt[j] - alt[i], u[j] - u[i], v[j] - v[i],
            w[j] - w[i])


@njit(cache=True, inline="always")
def statebased_pair(dx: float, dy: float, dz: float, du: float, dv: float, dw: float, rpz: float, hpz: float,
                    tlook: float) -> tuple[bool, float, float, float, float, bool]:
    """BlueSky STATEBASED on one pair: (conflict, tcpa, dcpa squared, tinconf, toutconf, LoS now).

    The horizontal test comes first: most candidate pairs fail it, and then no
    square root or vertical computation is needed.
    """
    r2 = rpz * rpz
    dist2 = dx * dx + dy * dy
    dv2 = du * du + dv * dv
    if abs(dv2) < 1e-6:
        dv2 = 1e-6
    tcpa = -(du * dx + dv * dy) / dv2
    dcpa2 = abs(dist2 - tcpa * tcpa * dv2)
    los = dist2 < r2 and abs(dz) < hpz
    if dcpa2 >= r2:
        return False, tcpa, dcpa2, 0.0, 0.0, los
    dtinhor = math.sqrt(max(0.0, r2 - dcpa2)) / math.sqrt(dv2)
    tinhor = tcpa - dtinhor
    touthor = tcpa + dtinhor
    # Vertical, as BlueSky writes it (its floor on |dvs| is not sign-symmetric).
    dvs = dw
    if abs(dvs) < 1e-6:
        dvs = 1e-6
    tcrosshi = (dz + hpz) / -dvs
    tcrosslo = (dz - hpz) / -dvs
    tinconf = max(min(tcrosshi, tcrosslo), tinhor)
    toutconf = min(max(tcrosshi, tcrosslo), touthor)
    conf = tinconf <= toutconf and toutconf > 0.0 and tinconf < tlook
    return conf, tcpa, dcpa2, tinconf, toutconf, los


@njit(cache=True)
def statebased(
    lat: np.ndarray,
    lon: np.ndarray,
    alt: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    pi: np.ndarray,
    pj: np.ndarray,
    rpz: float,
    hpz: float,
    tlook: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """BlueSky STATEBASED conflict test on candidate pairs.

    A pair is in conflict when, flying on, the horizontal distance drops
    under ``rpz`` while the altitude difference is under ``hpz``, starting
    within ``tlook`` seconds (and not ended already).

    Returns:
        mask (per candidate), tcpa [s], dcpa [m], tinconf [s], toutconf [s],
        and the LoS mask (inside the protected zone now).
    """
    m = pi.shape[0]
    conf = np.zeros(m, dtype=np.bool_)
    los = np.zeros(m, dtype=np.bool_)
    tcpa_out = np.zeros(m)
    dcpa_out = np.zeros(m)
    tin_out = np.zeros(m)
    tout_out = np.zeros(m)
    latr, lonr, ch, sh = pair_frame(lat, lon)
    for k in range(m):
        dx, dy, dz, du, dv, dw = relative_state(latr, lonr, ch, sh, alt, u, v, w, pi[k], pj[k])
        conf[k], tcpa_out[k], dcpa2, tin_out[k], tout_out[k], los[k] = statebased_pair(
            dx, dy, dz, du, dv, dw, rpz, hpz, tlook)
        dcpa_out[k] = math.sqrt(dcpa2)
    return conf, tcpa_out, dcpa_out, tin_out, tout_out, los


@njit(cache=True, inline="always")
def _interval_inside(p: float, q: float, c: float, lo: float, hi: float) -> tuple[float, float]:
    """Sub-interval of [lo, hi] where p*t^2 + q*t + c < 0 (p >= 0); empty if a > b."""
    if p <= 1e-12:
        if abs(q) <= 1e-12:
            return (lo, hi) if c < 0.0 else (1.0, -1.0)
        root = -c / q
        if q > 0.0:
            return lo, min(hi, root)
        return max(lo, root), hi
    disc = q * q - 4.0 * p * c
    if disc <= 0.0:
        return 1.0, -1.0
    sq = math.sqrt(disc)
    return max(lo, (-q - sq) / (2.0 * p)), min(hi, (-q + sq) / (2.0 * p))


@njit(cache=True, inline="always")
def encounter_pair(dx: float, dy: float, dz: float, du: float, dv: float, dw: float, lo: float, cylinder: bool,
               radius: float, half_height: float) -> tuple[bool, float, float, float, float]:
    """Inside-interval of one pair in [lo, 0]: (inside, t_in, t_out, min 3-D distance, its time)."""
    if cylinder:
        a, b = _interval_inside(du * du + dv * dv, 2.0 * (dx * du + dy * dv), dx * dx + dy * dy - radius * radius,
                                lo, 0.0)
        if a > b:
            return False, 0.0, 0.0, 0.0, 0.0
        a, b = _interval_inside(dw * dw, 2.0 * dz * dw, dz * dz - half_height * half_height, a, b)
    else:
        a, b = _interval_inside(du * du + dv * dv + dw * dw, 2.0 * (dx * du + dy * dv + dz * dw),
                                dx * dx + dy * dy + dz * dz - radius * radius, lo, 0.0)
    if a > b:
        return False, 0.0, 0.0, 0.0, 0.0
    vv = du * du + dv * dv + dw * dw
    tau = -(dx * du + dy * dv + dz * dw) / vv if vv > 1e-12 else b
    tau = min(max(tau, a), b)
    ex = dx + du * tau
    ey = dy + dv * tau
    ez = dz + dw * tau
    return True, a, b, math.sqrt(ex * ex + ey * ey + ez * ez), tau


@njit(cache=True)
def volume_encounters(
    lat: np.ndarray,
    lon: np.ndarray,
    alt: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    lookback: np.ndarray,
    pi: np.ndarray,
    pj: np.ndarray,
    cylinder: bool,
    radius: float,
    half_height: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Which candidate pairs were inside a separation volume during the last interval.

    The interval for a pair is ``[-lookback, 0]`` seconds relative to now
    (``lookback`` per aircraft: the time since the last check, or since
    creation). The volume is a sphere of ``radius`` (3-D slant distance) or,
    with ``cylinder``, a horizontal radius and vertical half-height.

    Returns:
        inside mask, entry time, exit time (relative to now, in the interval),
        minimum 3-D distance while inside [m], and the time of that minimum.
    """
    m = pi.shape[0]
    inside = np.zeros(m, dtype=np.bool_)
    t_in = np.zeros(m)
    t_out = np.zeros(m)
    dmin = np.zeros(m)
    t_min = np.zeros(m)
    latr, lonr, ch, sh = pair_frame(lat, lon)
    for k in range(m):
        i = pi[k]
        j = pj[k]
        dx, dy, dz, du, dv, dw = relative_state(latr, lonr, ch, sh, alt, u, v, w, i, j)
        lo = -min(lookback[i], lookback[j])
        inside[k], t_in[k], t_out[k], dmin[k], t_min[k] = encounter_pair(dx, dy, dz, du, dv, dw, lo, cylinder, radius,
                                                                     half_height)
    return inside, t_in, t_out, dmin, t_min


@njit(cache=True)
def slant_distances(
    lat: np.ndarray, lon: np.ndarray, alt: np.ndarray, pi: np.ndarray, pj: np.ndarray
) -> np.ndarray:
    """3-D distance [m] of each pair now."""
    m = pi.shape[0]
    out = np.empty(m)
    for k in range(m):
        i = pi[k]
        j = pj[k]
        dlat = math.radians(lat[j] - lat[i])
        dlon = math.radians(((lon[j] - lon[i]) + 180.0) % 360.0 - 180.0)
        cavelat = math.cos(math.radians(lat[i] + lat[j]) * 0.5)
        dx = R_EARTH * dlon * cavelat
        dy = R_EARTH * dlat
        dz = alt[j] - alt[i]
        out[k] = math.sqrt(dx * dx + dy * dy + dz * dz)
    return out


@njit(cache=True)
def nearest_per_aircraft(n: int, pi: np.ndarray, pj: np.ndarray, d: np.ndarray,
                         max_range: float) -> tuple[np.ndarray, np.ndarray]:
    """Per aircraft, the smallest pair distance within ``max_range`` and the other aircraft (-1: none)."""
    dist = np.full(n, np.inf)
    idx = np.full(n, -1, dtype=np.int64)
    for k in range(pi.shape[0]):
        dd = d[k]
        if dd > max_range:
            continue
        a = pi[k]
        b = pj[k]
        if dd < dist[a]:
            dist[a] = dd
            idx[a] = b
        if dd < dist[b]:
            dist[b] = dd
            idx[b] = a
    return dist, idx
