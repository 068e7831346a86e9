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
