"""Everything a conflict check computes, in one compiled pass.

The traffic kernel advances 1,000 aircraft by one second in about a
millisecond, so a check that calls a dozen compiled functions and builds the
intermediate arrays in Python costs as much as the flight itself. This pass
reads the traffic matrix once and returns only what the service keeps: the
conflict pairs of state-based detection, the pairs inside each separation
volume during the last interval (with their closest points), and the
closest-intruder distances.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aamsim.conflicts.grid import NO_PAIR_LIMIT, Strips, build_strips, candidate_pairs, snapshot_arrays, swept_boxes
from aamsim.conflicts.pairs import encounter_pair, relative_state, slant_distances, statebased_pair
from aamsim.numba_cache import njit
from aamsim.units import R_EARTH


class Detection(NamedTuple):
    """What one conflict check (:func:`detect_all`) finds; slots are rows of the traffic matrix.

    Conflicts (STATEBASED, BlueSky's names) are the pairs ``conflict_i < conflict_j``; losses of separation
    the pairs ``los_i, los_j``. Events are the pairs inside a separation volume during the last interval,
    grouped by volume (``inside_count[q]`` of volume q, in the order of the volumes).
    """

    conflict_i: np.ndarray  # int64, slot of the first aircraft of each conflict
    conflict_j: np.ndarray  # int64, slot of the second
    tcpa: np.ndarray  # s, time to the closest point of approach
    dcpa: np.ndarray  # m, horizontal distance at it
    tinconf: np.ndarray  # s, time to the loss of separation
    los_i: np.ndarray  # int64, pairs in loss of separation now
    los_j: np.ndarray  # int64
    inconf: np.ndarray  # bool, per aircraft: in a conflict
    tcpamax: np.ndarray  # s, per aircraft: the largest tcpa of its conflicts (0 when none)
    event_volume: np.ndarray  # int64, per inside pair: its volume's index
    event_i: np.ndarray  # int64, slots of the inside pair
    event_j: np.ndarray  # int64
    event_t_in: np.ndarray  # s, entry time in the interval
    event_t_out: np.ndarray  # s, exit time
    event_dmin: np.ndarray  # m, smallest distance inside
    event_t_min: np.ndarray  # s, time of that distance
    event_state: np.ndarray  # (pairs, 12): lat, lon, alt of i, of j, east/north/up velocity of i, of j at t_min
    inside_count: np.ndarray  # int64, per volume: its inside pairs
    closest: np.ndarray  # m, per aircraft: the closest intruder within the closest range (inf beyond)
    min_distance: float  # m, the smallest pair distance (now, or inside a volume during the interval)
    cut: bool  # True when a pair search stopped at max_pairs


@njit(cache=True)
def _sweep_statebased(strips: Strips, state: np.ndarray, rpz: float, hpz: float, tlook: float, ci: np.ndarray,
                      cj: np.ndarray, ctcpa: np.ndarray, cdcpa: np.ndarray, ctin: np.ndarray, li: np.ndarray,
                      lj: np.ndarray, inconf: np.ndarray, tcpamax: np.ndarray, limit: int) -> tuple[int, int]:
    """STATEBASED on every pair of overlapping boxes, as the strip sweep finds them.

    ``state``: per strip entry, the aircraft's latr, lonr, ch, sh (:func:`pair_frame`),
    alt, u, v, w, in entry order, so that the inner loop reads memory in sequence.
    Conflicts and LoS pairs are written while they fit the output arrays; the
    counts are returned (the caller runs it again with larger arrays if needed).
    The sweep stops after the entry whose pairs bring either count to ``limit``.
    Testing pairs as they are found saves writing and re-reading the candidates:
    the scan (as in grid._sweep) emitting entry pairs and a second loop testing
    them measured 11 % slower at N = 1,000 and 42 % at N = 10,000, so the scan's
    loop is written here again instead of shared.
    """
    sx0, sx1, sy0, sy1, sid, sbk, strip_start, first, x0, inv_qx = strips
    buf = np.empty(sid.shape[0], dtype=np.int64)
    ccap = ci.shape[0]
    lcap = li.shape[0]
    nc = 0
    nl = 0
    r2 = rpz * rpz
    r2_margin = r2 * (1.0 + 1e-6)
    for strip in range(strip_start.shape[0] - 1):
        stop = strip_start[strip + 1]
        for a in range(strip_start[strip], stop):
            # Overlapping later entries, as in grid._sweep (see there).
            ax0 = sx0[a]
            ax1 = sx1[a]
            ay0 = sy0[a]
            ay1 = sy1[a]
            a_first = first[a]
            last_bucket = np.int64((ax1 - x0) * inv_qx)
            k = 0
            for b in range(a + 1, stop):
                if sbk[b] > last_bucket:
                    break
                buf[k] = b
                k += (sx0[b] <= ax1) & (ax0 <= sx1[b]) & (sy0[b] <= ay1) & (ay0 <= sy1[b]) & (a_first | first[b])
            if k == 0:
                continue
            ida = sid[a]
            la, lo, ca, sa, za, ua, va, wa = (state[a, 0], state[a, 1], state[a, 2], state[a, 3], state[a, 4],
                                               state[a, 5], state[a, 6], state[a, 7])
            for t in range(k):
                b = buf[t]
                idb = sid[b]
                i = min(ida, idb)
                j = max(ida, idb)
                # j relative to i (the pair's order in every output), as relative_state computes it.
                sign = 1.0 if ida < idb else -1.0
                dlon = sign * (state[b, 1] - lo)
                if dlon >= math.pi:
                    dlon -= 2.0 * math.pi
                elif dlon < -math.pi:
                    dlon += 2.0 * math.pi
                dx = R_EARTH * dlon * (ca * state[b, 2] - sa * state[b, 3])
                dy = R_EARTH * sign * (state[b, 0] - la)
                du = sign * (state[b, 5] - ua)
                dv = sign * (state[b, 6] - va)
                # Most candidates pass wide: the closest horizontal distance, cross^2 / dv2, is
                # over rpz. Rejecting those here saves the test's division. The margin (1e-6
                # relative) covers the rounding of BlueSky's dist2 - tcpa^2 dv2 up to
                # distances of 1e4 rpz, so this never rejects a pair the test would accept.
                dist2 = dx * dx + dy * dy
                dv2 = du * du + dv * dv
                cross = dx * dv - dy * du
                if r2 <= dist2 < 1e8 * r2 and dv2 >= 1e-6 and cross * cross > r2_margin * dv2:
                    continue
                dz = sign * (state[b, 4] - za)
                dw = sign * (state[b, 7] - wa)
                conf, tcpa, dcpa2, tin, _tout, los = statebased_pair(dx, dy, dz, du, dv, dw, rpz, hpz, tlook)
                if los:
                    if nl < lcap:
                        li[nl] = i
                        lj[nl] = j
                    nl += 1
                if conf:
                    if nc < ccap:
                        ci[nc] = i
                        cj[nc] = j
                        ctcpa[nc] = tcpa
                        cdcpa[nc] = math.sqrt(dcpa2)
                        ctin[nc] = tin
                    nc += 1
                    inconf[i] = True
                    inconf[j] = True
                    tcpamax[i] = max(tcpamax[i], tcpa)
                    tcpamax[j] = max(tcpamax[j], tcpa)
            if nc >= limit or nl >= limit:
                return nc, nl
    return nc, nl


@njit(cache=True)
def _conflicts(x: np.ndarray, y: np.ndarray, err: float, latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray,
               sh: np.ndarray, alt: np.ndarray, u: np.ndarray, v: np.ndarray, w: np.ndarray, rpz: float, hpz: float,
               tlook: float, cap_hint: int, limit: int) -> tuple:
    """State-based conflict detection over [0, tlook]: conflicts, LoS pairs and per-aircraft flags.

    ``cap_hint``: expected number of conflicts (the previous check's), to size the outputs;
    ``limit``: the search stops once it has this many conflicts or LoS pairs.
    """
    n = alt.shape[0]
    inconf = np.zeros(n, dtype=np.bool_)
    tcpamax = np.zeros(n)
    if n < 2:
        no_int = np.empty(0, dtype=np.int64)
        no_float = np.empty(0)
        return no_int, no_int, no_float, no_float, no_float, no_int, no_int, inconf, tcpamax
    xmin, xmax, ymin, ymax, cell = swept_boxes(x, y, u, v, np.zeros(n), np.full(n, tlook), rpz, err)
    strips = build_strips(xmin, xmax, ymin, ymax, cell)
    sid = strips[4]
    state = np.empty((sid.shape[0], 8))
    for e in range(sid.shape[0]):
        k = sid[e]
        state[e, 0] = latr[k]
        state[e, 1] = lonr[k]
        state[e, 2] = ch[k]
        state[e, 3] = sh[k]
        state[e, 4] = alt[k]
        state[e, 5] = u[k]
        state[e, 6] = v[k]
        state[e, 7] = w[k]
    ccap = min(max(4 * n, cap_hint), limit) + n + 64
    lcap = min(max(n, cap_hint // 4), limit) + n + 64
    while True:
        ci = np.empty(ccap, dtype=np.int64)
        cj = np.empty(ccap, dtype=np.int64)
        ctcpa = np.empty(ccap)
        cdcpa = np.empty(ccap)
        ctin = np.empty(ccap)
        li = np.empty(lcap, dtype=np.int64)
        lj = np.empty(lcap, dtype=np.int64)
        nc, nl = _sweep_statebased(strips, state, rpz, hpz, tlook, ci, cj, ctcpa, cdcpa, ctin, li, lj, inconf,
                                   tcpamax, limit)
        if nc <= ccap and nl <= lcap:
            return ci[:nc], cj[:nc], ctcpa[:nc], cdcpa[:nc], ctin[:nc], li[:nl], lj[:nl], inconf, tcpamax
        ccap = max(ccap, nc)
        lcap = max(lcap, nl)


@njit(cache=True)
def volume_pass(lat: np.ndarray, lon: np.ndarray, latr: np.ndarray, lonr: np.ndarray, ch: np.ndarray,
                 sh: np.ndarray, alt: np.ndarray, u: np.ndarray, v: np.ndarray, w: np.ndarray, lookback: np.ndarray,
                 pi: np.ndarray, pj: np.ndarray, radii: np.ndarray, cylinder: np.ndarray, half_heights: np.ndarray,
                 closest_range: float, r_earth: float) -> tuple:
    """Pairs inside each volume over their last interval, closest-intruder distances and the smallest distance
    (between any candidate pair now, or between a pair inside a volume during the interval)."""
    n = alt.shape[0]
    m = pi.shape[0]
    nv = radii.shape[0]
    inside = np.zeros((nv, m), dtype=np.bool_)
    t_in = np.empty((nv, m))
    t_out = np.empty((nv, m))
    dmin = np.empty((nv, m))
    t_min = np.empty((nv, m))
    count = np.zeros(nv, dtype=np.int64)
    closest = np.full(n, np.inf)
    dnow = np.inf
    for k in range(m):
        i = pi[k]
        j = pj[k]
        dx, dy, dz, du, dv, dw = relative_state(latr, lonr, ch, sh, alt, u, v, w, i, j)
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        dnow = min(dnow, d)
        if d <= closest_range:
            closest[i] = min(closest[i], d)
            closest[j] = min(closest[j], d)
        lo = -min(lookback[i], lookback[j])
        for q in range(nv):
            ok, a, b, dm, tau = encounter_pair(dx, dy, dz, du, dv, dw, lo, cylinder[q], radii[q], half_heights[q])
            inside[q, k] = ok
            t_in[q, k] = a
            t_out[q, k] = b
            dmin[q, k] = dm
            t_min[q, k] = tau
            count[q] += ok
    total = 0
    for q in range(nv):
        total += count[q]
    eq = np.empty(total, dtype=np.int64)
    ei = np.empty(total, dtype=np.int64)
    ej = np.empty(total, dtype=np.int64)
    etin = np.empty(total)
    etout = np.empty(total)
    edmin = np.empty(total)
    etmin = np.empty(total)
    epos = np.empty((total, 12))
    e = 0
    for q in range(nv):
        for k in range(m):
            if not inside[q, k]:
                continue
            tau = t_min[q, k]
            eq[e] = q
            ei[e] = pi[k]
            ej[e] = pj[k]
            etin[e] = t_in[q, k]
            etout[e] = t_out[q, k]
            edmin[e] = dmin[q, k]
            etmin[e] = tau
            # Positions on the straight paths at the closest point, and the velocities.
            for c in range(2):
                s = pi[k] if c == 0 else pj[k]
                epos[e, 3 * c] = lat[s] + math.degrees(v[s] * tau / r_earth)
                epos[e, 3 * c + 1] = lon[s] + math.degrees(
                    u[s] * tau / (r_earth * max(1e-6, math.cos(math.radians(lat[s])))))
                epos[e, 3 * c + 2] = alt[s] + w[s] * tau
                epos[e, 6 + 3 * c] = u[s]
                epos[e, 7 + 3 * c] = v[s]
                epos[e, 8 + 3 * c] = w[s]
            dnow = min(dnow, dmin[q, k])
            e += 1
    return eq, ei, ej, etin, etout, edmin, etmin, epos, count, closest, dnow


def detect_all(
    F: np.ndarray,
    n: int,
    rows: np.ndarray,
    r_earth: float,
    lookback: np.ndarray,
    cd_on: bool,
    rpz: float,
    hpz: float,
    tlook: float,
    radii: np.ndarray,
    cylinder: np.ndarray,
    half_heights: np.ndarray,
    closest_range: float,
    cap_hint: int = 0,
    max_pairs: int = NO_PAIR_LIMIT,
) -> Detection:
    """One conflict check on the first ``n`` aircraft of the traffic matrix ``F``.

    Args:
        rows: row numbers of lat, lon, alt, ground speed east and north, vs in ``F``.
        lookback: per aircraft, seconds back to the previous check (or its creation).
        cd_on: run BlueSky STATEBASED detection with ``rpz`` [m], ``hpz`` [m] and ``tlook`` [s].
        radii, cylinder, half_heights: the separation volumes.
        closest_range: closest-intruder distances beyond this [m] are inf.
        cap_hint: expected number of conflicts (sizes the output; any number is correct).
        max_pairs: each pair search (conflicts, LoS, pairs near enough for a volume) stops once it has
            found this many; :attr:`Detection.cut` says whether one did.

    Returns:
        The conflicts, losses of separation, inside pairs of every volume, closest-intruder distances
        and whether a pair search stopped at ``max_pairs``: a :class:`Detection`.
    """
    # The compiled pass returns a plain tuple and the record is made here, in Python: Numba boxes a
    # named tuple by calling its class, Python code that a pending signal (Ctrl-C, an alarm) then
    # interrupts inside the boxing, which crashed the process (tests/test_compiled_errors.py).
    return Detection._make(_detect_all(F, n, rows, r_earth, lookback, cd_on, rpz, hpz, tlook, radii, cylinder,
                                       half_heights, closest_range, cap_hint, max_pairs))


@njit(cache=True)
def _detect_all(
    F: np.ndarray,
    n: int,
    rows: np.ndarray,
    r_earth: float,
    lookback: np.ndarray,
    cd_on: bool,
    rpz: float,
    hpz: float,
    tlook: float,
    radii: np.ndarray,
    cylinder: np.ndarray,
    half_heights: np.ndarray,
    closest_range: float,
    cap_hint: int = 0,
    max_pairs: int = NO_PAIR_LIMIT,
) -> tuple:
    """:func:`detect_all`, compiled: the fields of a :class:`Detection` as a tuple, in its order."""
    lat, lon, alt, u, v, w, x, y, err, latr, lonr, ch, sh = snapshot_arrays(F, n, rows, r_earth)
    zeros = np.zeros(n)
    empty = np.empty(0, dtype=np.int64)
    conflicts = _conflicts(x, y, err, latr, lonr, ch, sh, alt, u, v, w, rpz, hpz, tlook, cap_hint, max_pairs) \
        if cd_on else _conflicts(x[:0], y[:0], err, latr[:0], lonr[:0], ch[:0], sh[:0], alt[:0], u[:0], v[:0],
                                 w[:0], rpz, hpz, tlook, 0, max_pairs)
    radius = closest_range
    for q in range(radii.shape[0]):
        radius = max(radius, radii[q])
    if n >= 2:
        xmin, xmax, ymin, ymax, cell = swept_boxes(x, y, u, v, -lookback, zeros, radius, err)
        pi, pj = candidate_pairs(xmin, xmax, ymin, ymax, cell, max_pairs)
    else:
        pi, pj = empty, empty
    volumes = volume_pass(lat, lon, latr, lonr, ch, sh, alt, u, v, w, lookback, pi, pj, radii, cylinder,
                           half_heights, closest_range, r_earth)
    cut = pi.shape[0] >= max_pairs or conflicts[0].shape[0] >= max_pairs or conflicts[5].shape[0] >= max_pairs
    return conflicts + volumes + (cut,)


_HASH_MULTIPLIER = np.int64(-7046029254386353131)  # 2**64 / golden ratio, as a signed 64-bit integer


@njit(cache=True)
def pairs_now(F: np.ndarray, n: int, rows: np.ndarray, r_earth: float, radius: float,
              limit: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs (slots ``pi < pj``) of the first ``n`` aircraft within ``radius`` [m] horizontally or closer
    (a superset: the pair search's boxes), and their 3-D distances [m] now.

    One compiled call for what :func:`aamsim.conflicts.service.pairs_within` did in four (snapshot,
    boxes, search, distances; the same functions, so the same pairs in the same order): an observation
    asks it once per decision and world, where the calls' fixed costs were most of the answer.
    ``rows``: the rows of lat, lon, alt, ground speed east and north, and vertical speed in ``F``.
    """
    lat, lon, alt, u, v, _w, x, y, err, _latr, _lonr, _ch, _sh = snapshot_arrays(F, n, rows, r_earth)
    if n < 2:
        empty = np.empty(0, dtype=np.int64)
        return empty, empty, np.empty(0)
    zeros = np.zeros(n)
    xmin, xmax, ymin, ymax, cell = swept_boxes(x, y, u, v, zeros, zeros, radius, err)
    pi, pj = candidate_pairs(xmin, xmax, ymin, ymax, cell, limit)
    return pi, pj, slant_distances(lat, lon, alt, pi, pj)


@njit(cache=True)
def new_pair_count(serial: np.ndarray, ci: np.ndarray, cj: np.ndarray, previous: np.ndarray) -> tuple[int, np.ndarray]:
    """How many of the pairs (slots ci, cj) are not among the ``previous`` pair keys; and their keys.

    A pair's key is built from the aircraft's ``serial`` numbers (stable over the run),
    smaller first. The previous keys go into an open-addressing hash table: with
    about a thousand conflicts a sort cost three times more in the run (its code
    and branch history are cold after the step kernel).
    """
    m = ci.shape[0]
    keys = np.empty(m, dtype=np.int64)
    for k in range(m):
        a = serial[ci[k]]
        b = serial[cj[k]]
        keys[k] = min(a, b) * (np.int64(1) << 32) + max(a, b)
    bits = 4
    while (1 << bits) < 2 * previous.shape[0]:
        bits += 1
    mask = (np.int64(1) << bits) - 1
    table = np.full(mask + 1, -1, dtype=np.int64)  # keys are never negative
    for k in range(previous.shape[0]):
        h = ((previous[k] * _HASH_MULTIPLIER) >> (64 - bits)) & mask  # Fibonacci hashing
        while table[h] != -1:
            h = (h + 1) & mask
        table[h] = previous[k]
    new = 0
    for k in range(m):
        h = ((keys[k] * _HASH_MULTIPLIER) >> (64 - bits)) & mask
        while table[h] != -1 and table[h] != keys[k]:
            h = (h + 1) & mask
        new += table[h] == -1
    return new, keys

