"""Observation kernels (Numba): nearest intruders and relative features.

Relative positions use the same equirectangular formulas as conflict
detection (east ``x``, north ``y`` in metres, per pair at the mean latitude);
distances between aircraft are 3-D slant distances.
"""

from __future__ import annotations

import math

import numpy as np

from aamsim.numba_cache import njit
from aamsim.units import R_EARTH


@njit(cache=True, inline="always")
def rel_xy(lat0: float, lon0: float, lat1: float, lon1: float) -> tuple[float, float]:
    """East/north offset [m] of point 1 from point 0."""
    dlat = math.radians(lat1 - lat0)
    dlon = math.radians(((lon1 - lon0) + 180.0) % 360.0 - 180.0)
    cav = math.cos(math.radians(lat0 + lat1) * 0.5)
    return R_EARTH * dlon * cav, R_EARTH * dlat


@njit(cache=True)
def nearest_neighbours(
    n: int, agents: np.ndarray, pi: np.ndarray, pj: np.ndarray, d: np.ndarray, k: int, max_range: float
) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` closest aircraft of each agent within ``max_range`` (closest first; -1 pads).

    Equal distances keep the (deterministic) order of the pair search.
    """
    counts = np.zeros(n + 1, dtype=np.int64)
    for e in range(pi.shape[0]):
        if d[e] <= max_range:
            counts[pi[e] + 1] += 1
            counts[pj[e] + 1] += 1
    for s in range(n):
        counts[s + 1] += counts[s]
    fill = counts[:-1].copy()
    other = np.empty(counts[n], dtype=np.int64)
    dist = np.empty(counts[n])
    for e in range(pi.shape[0]):
        if d[e] <= max_range:
            a = pi[e]
            b = pj[e]
            other[fill[a]] = b
            dist[fill[a]] = d[e]
            fill[a] += 1
            other[fill[b]] = a
            dist[fill[b]] = d[e]
            fill[b] += 1
    na = agents.shape[0]
    nbr = np.full((na, k), -1, dtype=np.int64)
    nbr_d = np.full((na, k), np.inf)
    for q in range(na):
        s = agents[q]
        lo = counts[s]
        hi = counts[s + 1]
        m = hi - lo
        if m == 0:
            continue
        order = np.argsort(dist[lo:hi], kind="mergesort")
        take = min(k, m)
        for t in range(take):
            nbr[q, t] = other[lo + order[t]]
            nbr_d[q, t] = dist[lo + order[t]]
    return nbr, nbr_d


@njit(cache=True, inline="always")
def _to_frame(x: float, y: float, sin_t: float, cos_t: float, rotate: bool) -> tuple[float, float]:
    """East/north -> (along-track, right of track) when ``rotate``; unchanged otherwise."""
    if rotate:
        return x * sin_t + y * cos_t, x * cos_t - y * sin_t
    return x, y


@njit(cache=True)
def corridor_features(
    agents: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    alt: np.ndarray,
    hdg: np.ndarray,
    trk: np.ndarray,
    ax: np.ndarray,
    gs: np.ndarray,
    ddest: np.ndarray,
    wpt_lat: np.ndarray,
    wpt_lon: np.ndarray,
    nbr: np.ndarray,
    nbr_d: np.ndarray,
    scales: np.ndarray,
    track_frame: bool,
    relative_velocity: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ownship and intruder feature arrays of the corridor use case (already scaled).

    scales = [hdg, alt, acc, spd, pos, dalt] divisors.
    Ownship (5 + 2 N_wpt): hdg, z, a, v, d_dest, then (x_wpt - x_o, y_wpt - y_o) per waypoint.
    Intruder (7 + 2 N_wpt): x_i - x_o, y_i - y_o, z_i - z_o, a_i, v_i, d_dest_i, d_io, then the
    intruder's waypoints relative to the ownship; with ``relative_velocity`` two more: the
    intruder's velocity relative to the ownship. Horizontal vectors are east/north (the paper)
    or, with ``track_frame``, along and right of the ownship's track.
    """
    hs, zs, acs, vs, ps, dzs = scales[0], scales[1], scales[2], scales[3], scales[4], scales[5]
    na = agents.shape[0]
    nw = wpt_lat.shape[1]
    k = nbr.shape[1]
    extra = 2 if relative_velocity else 0
    own = np.zeros((na, 5 + 2 * nw), dtype=np.float32)
    intr = np.zeros((na, k, 7 + 2 * nw + extra), dtype=np.float32)
    mask = np.zeros((na, k), dtype=np.float32)
    for q in range(na):
        o = agents[q]
        t_o = math.radians(trk[o])
        sin_t, cos_t = math.sin(t_o), math.cos(t_o)
        u_o, v_o = gs[o] * sin_t, gs[o] * cos_t
        own[q, 0] = hdg[o] / hs
        own[q, 1] = alt[o] / zs
        own[q, 2] = ax[o] / acs
        own[q, 3] = gs[o] / vs
        own[q, 4] = ddest[o] / ps
        for j in range(nw):
            x, y = rel_xy(lat[o], lon[o], wpt_lat[o, j], wpt_lon[o, j])
            x, y = _to_frame(x, y, sin_t, cos_t, track_frame)
            own[q, 5 + 2 * j] = x / ps
            own[q, 6 + 2 * j] = y / ps
        for m in range(k):
            i = nbr[q, m]
            if i < 0:
                break
            mask[q, m] = 1.0
            x, y = rel_xy(lat[o], lon[o], lat[i], lon[i])
            x, y = _to_frame(x, y, sin_t, cos_t, track_frame)
            intr[q, m, 0] = x / ps
            intr[q, m, 1] = y / ps
            intr[q, m, 2] = (alt[i] - alt[o]) / dzs
            intr[q, m, 3] = ax[i] / acs
            intr[q, m, 4] = gs[i] / vs
            intr[q, m, 5] = ddest[i] / ps
            intr[q, m, 6] = nbr_d[q, m] / ps
            for j in range(nw):
                x, y = rel_xy(lat[o], lon[o], wpt_lat[i, j], wpt_lon[i, j])
                x, y = _to_frame(x, y, sin_t, cos_t, track_frame)
                intr[q, m, 7 + 2 * j] = x / ps
                intr[q, m, 8 + 2 * j] = y / ps
            if relative_velocity:
                t_i = math.radians(trk[i])
                du, dv = _to_frame(gs[i] * math.sin(t_i) - u_o, gs[i] * math.cos(t_i) - v_o, sin_t, cos_t,
                                   track_frame)
                intr[q, m, 7 + 2 * nw] = du / vs
                intr[q, m, 8 + 2 * nw] = dv / vs
    return own, intr, mask
