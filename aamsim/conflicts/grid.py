"""A uniform-grid spatial index for pair searches, compiled with Numba.

Each aircraft contributes an axis-aligned box in a local flat frame (metres):
a point grown by the search radius for proximity questions, or the box
swept by its straight-line path for look-ahead conflict detection. Two
aircraft are candidates when their boxes overlap; the index returns every
such pair exactly once (a pair is emitted only in the grid cell holding the
low corner of the boxes' intersection), so the candidate set is a superset of
the true answer and the exact test run on it gives the brute-force result.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_KEY_STRIDE = np.int64(1 << 31)


@njit(cache=True)
def candidate_pairs(
    xmin: np.ndarray, xmax: np.ndarray, ymin: np.ndarray, ymax: np.ndarray, cell: float
) -> tuple[np.ndarray, np.ndarray]:
    """All pairs (i < j) whose boxes overlap, each once.

    Args:
        xmin, xmax, ymin, ymax: box per aircraft [m].
        cell: grid cell size [m]; about the typical box size is best.
    """
    n = xmin.shape[0]
    if n < 2:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    cx0 = np.empty(n, dtype=np.int64)
    cx1 = np.empty(n, dtype=np.int64)
    cy0 = np.empty(n, dtype=np.int64)
    cy1 = np.empty(n, dtype=np.int64)
    for i in range(n):
        cx0[i] = np.int64(math.floor(xmin[i] / cell))
        cx1[i] = np.int64(math.floor(xmax[i] / cell))
        cy0[i] = np.int64(math.floor(ymin[i] / cell))
        cy1[i] = np.int64(math.floor(ymax[i] / cell))
    # Shift cell indices to start at 0 so that (cx, cy) packs into one key.
    bx = cx0.min()
    by = cy0.min()
    total = 0
    for i in range(n):
        cx0[i] -= bx
        cx1[i] -= bx
        cy0[i] -= by
        cy1[i] -= by
        total += (cx1[i] - cx0[i] + 1) * (cy1[i] - cy0[i] + 1)
    ny = cy1.max() + 1
    ncells = (cx1.max() + 1) * ny
    keys = np.empty(total, dtype=np.int64)
    owner = np.empty(total, dtype=np.int64)
    k = 0
    for i in range(n):
        for cx in range(cx0[i], cx1[i] + 1):
            for cy in range(cy0[i], cy1[i] + 1):
                keys[k] = cx * _KEY_STRIDE + cy
                owner[k] = i
                k += 1
    if ncells <= 4 * total + 1024:
        # Dense grid: a counting sort by cell is linear (and stable).
        dense = np.empty(total, dtype=np.int64)
        for e in range(total):
            dense[e] = (keys[e] // _KEY_STRIDE) * ny + keys[e] % _KEY_STRIDE
        counts = np.zeros(ncells + 1, dtype=np.int64)
        for e in range(total):
            counts[dense[e] + 1] += 1
        for c in range(ncells):
            counts[c + 1] += counts[c]
        order = np.empty(total, dtype=np.int64)
        for e in range(total):
            order[counts[dense[e]]] = e
            counts[dense[e]] += 1
    else:
        order = np.argsort(keys, kind="mergesort")
    cap = 1024
    pi = np.empty(cap, dtype=np.int64)
    pj = np.empty(cap, dtype=np.int64)
    m = 0
    start = 0
    while start < total:
        key = keys[order[start]]
        stop = start + 1
        while stop < total and keys[order[stop]] == key:
            stop += 1
        cell_x = key // _KEY_STRIDE
        cell_y = key % _KEY_STRIDE
        for a in range(start, stop):
            i = owner[order[a]]
            for b in range(a + 1, stop):
                j = owner[order[b]]
                if xmin[i] > xmax[j] or xmin[j] > xmax[i] or ymin[i] > ymax[j] or ymin[j] > ymax[i]:
                    continue
                # Emit in the cell of the intersection's low corner only.
                if max(cx0[i], cx0[j]) != cell_x or max(cy0[i], cy0[j]) != cell_y:
                    continue
                if m == cap:
                    cap *= 2
                    pi2 = np.empty(cap, dtype=np.int64)
                    pj2 = np.empty(cap, dtype=np.int64)
                    pi2[:m] = pi[:m]
                    pj2[:m] = pj[:m]
                    pi, pj = pi2, pj2
                if i < j:
                    pi[m] = i
                    pj[m] = j
                else:
                    pi[m] = j
                    pj[m] = i
                m += 1
        start = stop
    return pi[:m], pj[:m]


def local_frame(lat: np.ndarray, lon: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Flat x (east) / y (north) coordinates [m] around the mean position.

    Used only to find candidate pairs; the exact tests use per-pair formulas.
    Returns x, y and the largest relative scale error of the frame in the
    set (to grow search boxes by).
    """
    from aamsim.units import R_EARTH

    if len(lat) == 0:
        return np.empty(0), np.empty(0), 0.0
    lat0 = float(np.mean(lat))
    lon0 = float(lon[0])
    dlon = (lon - lon0 + 180.0) % 360.0 - 180.0
    coslat0 = math.cos(math.radians(lat0))
    x = np.radians(dlon) * R_EARTH * coslat0
    y = np.radians(lat - lat0) * R_EARTH
    spread = float(np.max(np.abs(lat - lat0))) if len(lat) else 0.0
    # cos(lat) varies over the set; per-pair distances use the mean of the pair.
    err = abs(math.cos(math.radians(abs(lat0) + spread)) / coslat0 - 1.0) if coslat0 > 0 else 1.0
    return x, y, err


@njit(cache=True)
def snapshot_arrays(F: np.ndarray, n: int, lat_row: int, lon_row: int, alt_row: int, gs_row: int, trk_row: int,
                    vs_row: int, r_earth: float) -> tuple:
    """Positions, velocities and the local flat frame of the first ``n`` aircraft in one pass.

    Returns lat, lon, alt, u (east), v (north), w (up), x, y and the frame's
    largest relative scale error (see :func:`local_frame`).
    """
    lat = np.empty(n)
    lon = np.empty(n)
    alt = np.empty(n)
    u = np.empty(n)
    v = np.empty(n)
    w = np.empty(n)
    x = np.empty(n)
    y = np.empty(n)
    if n == 0:
        return lat, lon, alt, u, v, w, x, y, 0.0
    lat0 = 0.0
    for i in range(n):
        lat[i] = F[lat_row, i]
        lat0 += lat[i]
    lat0 /= n
    lon0 = F[lon_row, 0]
    coslat0 = math.cos(math.radians(lat0))
    spread = 0.0
    for i in range(n):
        lon[i] = F[lon_row, i]
        alt[i] = F[alt_row, i]
        trk = math.radians(F[trk_row, i])
        gs = F[gs_row, i]
        u[i] = gs * math.sin(trk)
        v[i] = gs * math.cos(trk)
        w[i] = F[vs_row, i]
        dlon = ((lon[i] - lon0) + 180.0) % 360.0 - 180.0
        x[i] = math.radians(dlon) * r_earth * coslat0
        y[i] = math.radians(lat[i] - lat0) * r_earth
        spread = max(spread, abs(lat[i] - lat0))
    err = abs(math.cos(math.radians(abs(lat0) + spread)) / coslat0 - 1.0) if coslat0 > 0 else 1.0
    return lat, lon, alt, u, v, w, x, y, err


@njit(cache=True)
def swept_boxes(x: np.ndarray, y: np.ndarray, u: np.ndarray, v: np.ndarray, t0: np.ndarray, t1: np.ndarray,
                radius: float, frame_err: float) -> tuple:
    """Boxes around each straight path between t0 and t1 [s from now], grown for a pair distance ``radius``.

    The growth covers half the radius plus the flat frame's scale error over the
    largest relative displacement; returns the boxes and a good grid cell size.
    """
    n = x.shape[0]
    vmax = 0.0
    tmax = 0.0
    for i in range(n):
        vmax = max(vmax, math.hypot(u[i], v[i]))
        tmax = max(tmax, abs(t0[i]) + abs(t1[i]))
    reach = tmax * 2.0 * vmax + radius
    grow = 0.5 * radius * (1.0 + frame_err) + frame_err * reach + 1.0
    xmin = np.empty(n)
    xmax = np.empty(n)
    ymin = np.empty(n)
    ymax = np.empty(n)
    extent = np.empty(n)
    for i in range(n):
        xa = x[i] + u[i] * t0[i]
        xb = x[i] + u[i] * t1[i]
        ya = y[i] + v[i] * t0[i]
        yb = y[i] + v[i] * t1[i]
        xmin[i] = min(xa, xb) - grow
        xmax[i] = max(xa, xb) + grow
        ymin[i] = min(ya, yb) - grow
        ymax[i] = max(ya, yb) + grow
        extent[i] = max(xmax[i] - xmin[i], ymax[i] - ymin[i])
    cell = max(np.median(extent) if n else 1.0, 2.0 * grow, 1.0)
    return xmin, xmax, ymin, ymax, cell
