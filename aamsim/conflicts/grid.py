"""A spatial index for pair searches, compiled with Numba.

Each aircraft contributes an axis-aligned box in a local flat frame (metres):
a point grown by the search radius for proximity questions, or the box
swept by its straight-line path for look-ahead conflict detection. Two
aircraft are candidates when their boxes overlap; the index returns every
such pair exactly once, so the candidate set is a superset of the true answer
and the exact test run on it gives the brute-force result.

The index is a sweep in strips: boxes are filed into horizontal strips of
uniform height (a box spanning several strips is filed in each), ordered
within a strip by the low x edge (a counting sort on x buckets, linear in
time), and each box is tested only against the boxes after it whose low edge
lies before its high edge. A pair sharing several strips is emitted in the
lowest. This beat a square grid by 1.5-2x at 1,000 and 10,000 aircraft
(bench/bench_conflicts.py).
"""

from __future__ import annotations

import math

import numpy as np

from aamsim.numba_cache import njit

# build_strips' result: box bounds in strip/x order (x0, x1, y0, y1), the aircraft of each
# entry, its x bucket, where each strip starts, whether the entry is in its box's lowest
# strip, the x origin and the inverse of the bucket width.
Strips = tuple


@njit(cache=True)
def build_strips(xmin: np.ndarray, xmax: np.ndarray, ymin: np.ndarray, ymax: np.ndarray, cell: float) -> Strips:
    """The strip index of the boxes (at least one box).

    Args:
        xmin, xmax, ymin, ymax: box per aircraft [m].
        cell: strip height [m]; about the typical box size is best.
    """
    n = xmin.shape[0]
    total_extent = 0.0
    for i in range(n):
        total_extent += xmax[i] - xmin[i] + ymax[i] - ymin[i]
    if not math.isfinite(total_extent):
        # A NaN position would index outside the arrays below.
        raise ValueError("pair search: an aircraft has a non-finite position or velocity")
    y0 = ymin.min()
    x0 = xmin.min()
    # Never more strips than a few per box (sparse traffic over a large area, tiny boxes).
    cell = max(cell, (ymax.max() - y0) / (4 * n + 1024))
    # Strip and bucket numbers are products with the inverse widths (a division costs
    # several times more); any monotonic map of the coordinates keeps the index exact.
    inv_cell = 1.0 / cell
    cy0 = np.empty(n, dtype=np.int64)
    cy1 = np.empty(n, dtype=np.int64)
    total = 0
    for i in range(n):
        cy0[i] = np.int64((ymin[i] - y0) * inv_cell)
        cy1[i] = np.int64((ymax[i] - y0) * inv_cell)
        total += cy1[i] - cy0[i] + 1
    nstrips = cy1.max() + 1
    # Buckets of the box's low x edge: a quarter strip wide, fewer if that would
    # make the counting sort longer than the entries.
    span = xmin.max() - x0
    nb = min(np.int64(span / (0.25 * cell)) + 1, max(np.int64(1), (4 * total + 1024) // nstrips))
    inv_qx = nb / span if span > 0.0 else 1.0
    bucket = np.empty(n, dtype=np.int64)
    for i in range(n):
        bucket[i] = min(np.int64((xmin[i] - x0) * inv_qx), nb - 1)
    # Counting sort of the entries (one per strip a box touches) by strip, then by bucket.
    nkeys = nstrips * nb
    counts = np.zeros(nkeys + 1, dtype=np.int64)
    for i in range(n):
        for cy in range(cy0[i], cy1[i] + 1):
            counts[cy * nb + bucket[i] + 1] += 1
    for c in range(nkeys):
        counts[c + 1] += counts[c]
    strip_start = np.empty(nstrips + 1, dtype=np.int64)
    for c in range(nstrips + 1):
        strip_start[c] = counts[c * nb]
    # Box bounds copied in sorted order: the sweeps below read memory in sequence.
    sx0 = np.empty(total)
    sx1 = np.empty(total)
    sy0 = np.empty(total)
    sy1 = np.empty(total)
    sid = np.empty(total, dtype=np.int64)
    sbk = np.empty(total, dtype=np.int64)
    first = np.empty(total, dtype=np.bool_)
    for i in range(n):
        for cy in range(cy0[i], cy1[i] + 1):
            e = counts[cy * nb + bucket[i]]
            counts[cy * nb + bucket[i]] += 1
            sx0[e] = xmin[i]
            sx1[e] = xmax[i]
            sy0[e] = ymin[i]
            sy1[e] = ymax[i]
            sid[e] = i
            sbk[e] = bucket[i]
            first[e] = cy == cy0[i]
    return sx0, sx1, sy0, sy1, sid, sbk, strip_start, first, x0, inv_qx


NO_PAIR_LIMIT = 2**62  # no bound on a pair search


@njit(cache=True)
def candidate_pairs(
    xmin: np.ndarray, xmax: np.ndarray, ymin: np.ndarray, ymax: np.ndarray, cell: float,
    limit: int = NO_PAIR_LIMIT,
) -> tuple[np.ndarray, np.ndarray]:
    """All pairs (i < j) whose boxes overlap, each once; or, past ``limit`` pairs, those found so far.

    Args:
        xmin, xmax, ymin, ymax: box per aircraft [m].
        cell: strip height [m]; about the typical box size is best.
        limit: the search stops once it has found this many pairs (with the pairs of the box it was
            at, so at most ``limit`` plus the number of boxes): a caller tells a cut search by
            ``len(pi) >= limit``. Aircraft all on one spot make every pair a candidate.
    """
    if xmin.shape[0] < 2:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    strips = build_strips(xmin, xmax, ymin, ymax, cell)
    # Arrays are never grown inside the sweep: that makes Numba keep reference
    # counts in the loop (measured 4x slower). A generous first guess is filled;
    # when it is too small the sweep runs again with the exact size.
    cap = min(32 * strips[0].shape[0] + 1024, limit + strips[0].shape[0])
    pi = np.empty(cap, dtype=np.int64)
    pj = np.empty(cap, dtype=np.int64)
    m = _sweep(strips, pi, pj, limit)
    if m > cap:
        pi = np.empty(m, dtype=np.int64)
        pj = np.empty(m, dtype=np.int64)
        _sweep(strips, pi, pj, limit)
    return pi[:m], pj[:m]


@njit(cache=True)
def _sweep(strips: Strips, pi: np.ndarray, pj: np.ndarray, limit: int) -> int:
    """Overlapping pairs of the sorted entries, per strip, written to pi, pj while they fit. Returns their number.

    Stops after the entry whose pairs reach ``limit`` (the same place on a second run)."""
    sx0, sx1, sy0, sy1, sid, sbk, strip_start, first, x0, inv_qx = strips
    buf = np.empty(sid.shape[0], dtype=np.int64)
    cap = pi.shape[0]
    m = 0
    for strip in range(strip_start.shape[0] - 1):
        stop = strip_start[strip + 1]
        for a in range(strip_start[strip], stop):
            # The entries after a overlapping its box, whose pair with a belongs to this strip
            # (the lowest the two share: where one of them starts). Kept inline, not in a
            # function: Numba's call made it 4x slower. The loop body has no branch but the
            # end of the scan: every entry is written and the count advances by the test's
            # outcome, which saves a mispredicted branch on every other box (2.5x faster).
            ax0 = sx0[a]
            ax1 = sx1[a]
            ay0 = sy0[a]
            ay1 = sy1[a]
            a_first = first[a]
            # Later entries from a bucket past the one of this box's high x edge cannot overlap it.
            last_bucket = np.int64((ax1 - x0) * inv_qx)
            k = 0
            for b in range(a + 1, stop):
                if sbk[b] > last_bucket:
                    break
                buf[k] = b
                k += (sx0[b] <= ax1) & (ax0 <= sx1[b]) & (sy0[b] <= ay1) & (ay0 <= sy1[b]) & (a_first | first[b])
            i = sid[a]
            for t in range(k):
                j = sid[buf[t]]
                if m < cap:
                    pi[m] = min(i, j)
                    pj[m] = max(i, j)
                m += 1
            if m >= limit:
                return m
    return m


@njit(cache=True)
def snapshot_arrays(F: np.ndarray, n: int, rows: np.ndarray, r_earth: float) -> tuple:
    """Positions, velocities, the local flat frame and the pair-formula terms of the first ``n`` aircraft.

    Args:
        F: the traffic's field matrix; rows: the rows of lat, lon, alt, ground speed east
            and north, and vertical speed.

    The flat frame (x east, y north, metres) is centred on the mean latitude and
    the first aircraft's longitude; it only serves the pair search (the exact tests
    use per-pair formulas), which grows its boxes by the frame's scale error.

    Returns lat, lon, alt, u (east), v (north), w (up), x, y, the frame's largest
    relative scale error over the set, and the per-aircraft terms of
    :func:`aamsim.conflicts.pairs.pair_frame` (latr, lonr, ch, sh), all in one loop.
    """
    lat = np.empty(n)
    lon = np.empty(n)
    alt = np.empty(n)
    u = np.empty(n)
    v = np.empty(n)
    w = np.empty(n)
    x = np.empty(n)
    y = np.empty(n)
    latr = np.empty(n)
    lonr = np.empty(n)
    ch = np.empty(n)
    sh = np.empty(n)
    if n == 0:
        return lat, lon, alt, u, v, w, x, y, 0.0, latr, lonr, ch, sh
    r_lat, r_lon, r_alt, r_east, r_north, r_vs = rows[0], rows[1], rows[2], rows[3], rows[4], rows[5]
    lat0 = 0.0
    for i in range(n):
        lat0 += F[r_lat, i]
    lat0 /= n
    lon0 = F[r_lon, 0]
    coslat0 = math.cos(math.radians(lat0))
    spread = 0.0
    for i in range(n):
        la = F[r_lat, i]
        lo = F[r_lon, i]
        lat[i] = la
        lon[i] = lo
        alt[i] = F[r_alt, i]
        u[i] = F[r_east, i]
        v[i] = F[r_north, i]
        w[i] = F[r_vs, i]
        dlon = ((lo - lon0) + 180.0) % 360.0 - 180.0
        x[i] = math.radians(dlon) * r_earth * coslat0
        y[i] = math.radians(la - lat0) * r_earth
        spread = max(spread, abs(la - lat0))
        latr[i] = math.radians(la)
        lonr[i] = math.radians(lo)
        ch[i] = math.cos(0.5 * latr[i])
        sh[i] = math.sin(0.5 * latr[i])
    err = abs(math.cos(math.radians(abs(lat0) + spread)) / coslat0 - 1.0) if coslat0 > 0 else 1.0
    return lat, lon, alt, u, v, w, x, y, err, latr, lonr, ch, sh


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
    cell = max(extent.mean() if n else 1.0, 2.0 * grow, 1.0)
    return xmin, xmax, ymin, ymax, cell
