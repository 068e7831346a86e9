"""The conflict pairs BlueSky 1.1.1 hands its resolution: STATEBASED seen from each aircraft, with its bearings.

BlueSky resolves every directed pair (ownship, intruder) its state-based
detection lists. Its detection takes bearings and distances from its compiled
``kwikqdrdist_matrix``, which, called with the same aircraft on both sides,
computes the upper triangle and copies it into the lower one unchanged: for
aircraft ``i`` before ``j`` (BlueSky's index order), the pair ``(j, i)`` gets
the bearing from ``i`` to ``j``, not from ``j`` to ``i``. Seen from the later
aircraft the intruder's position is mirrored, so that aircraft finds its
conflict as the pair moves apart (after the closest point of approach) and not
as it closes; MVP then uses the same mirrored position. aamsim's conflict
service (:mod:`aamsim.conflicts`) reports each unordered pair once, from the
earlier aircraft's side, which is that side; the mirrored side is computed here,
for the resolution only, with BlueSky's arithmetic on the pair search of the
conflict service (:func:`aamsim.conflicts.service.search_pairs`).

BlueSky's index order is creation order; aamsim's slots keep it until an
aircraft is deleted (the last one then takes the freed slot), so the order
here is by creation time, then slot.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.conflicts.service import TrafficSnapshot as ConflictGeometry
from aamsim.conflicts.service import search_pairs, traffic_snapshot
from aamsim.units import NM, R_EARTH  # R_EARTH: also the radius of BlueSky's compiled geo

if TYPE_CHECKING:
    from aamsim.simapi import SimulationCore

_M2NM = 0.0005399568034557236
_DEG2RAD = 0.017453292519943295
_RAD2DEG = 57.29577951308232


@dataclass(frozen=True)
class DirectedConflicts:
    """Directed conflict pairs in BlueSky's order (ownship index, then intruder) and their detection data."""

    own: np.ndarray  # slots
    intr: np.ndarray
    qdr_deg: np.ndarray  # bearing BlueSky's detection uses (see the module docstring)
    dist_m: np.ndarray
    tcpa_s: np.ndarray
    tlos_s: np.ndarray  # time to loss of separation (tinconf)


def bluesky_order(sim: SimulationCore) -> np.ndarray:
    """Per slot, its rank in BlueSky's aircraft order (creation time, then slot)."""
    return creation_rank(np.asarray(sim.view.created_s))


def creation_rank(created_s: np.ndarray) -> np.ndarray:
    """Per row, its rank in BlueSky's aircraft order: creation time [s], then row."""
    n = created_s.shape[0]
    order = np.lexsort((np.arange(n), np.asarray(created_s)))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n)
    return rank


def detect(sim: SimulationCore, rpz_m: float, hpz_m: float, dtlook_s: float) -> DirectedConflicts:
    """BlueSky's STATEBASED conflict pairs, both sides of each pair tested, as its resolution receives them."""
    if sim.view.n < 2:
        return detect_on(sim.view, None, rpz_m, hpz_m, dtlook_s)
    return detect_on(sim.view, traffic_snapshot(sim), rpz_m, hpz_m, dtlook_s)  # type: ignore[arg-type]


def detect_on(view: Any, s: ConflictGeometry | None, rpz_m: float, hpz_m: float,
              dtlook_s: float) -> DirectedConflicts:
    """:func:`detect` on any traffic state: ``view`` has the arrays ``lat lon alt trk gs vs created_s`` and
    ``ids`` (a :class:`~aamsim.traffic.view.TrafficView` or a :class:`~aamsim.snapshots.TrafficSnapshot`),
    ``s`` is its conflict geometry (None with fewer than two aircraft)."""
    n = len(view.ids)
    empty_i = np.empty(0, dtype=np.int64)
    empty_f = np.empty(0)
    if n < 2 or s is None:
        return DirectedConflicts(empty_i, empty_i, empty_f, empty_f, empty_f, empty_f)
    # The mirrored side sees the pair's past: search over the look-ahead both ways.
    pa, pb = search_pairs(s, np.full(n, -dtlook_s), np.full(n, dtlook_s), rpz_m)
    rank = creation_rank(np.asarray(view.created_s))
    first = rank[pa] < rank[pb]
    i = np.where(first, pa, pb)  # earlier aircraft
    j = np.where(first, pb, pa)
    lat = np.asarray(view.lat) * _DEG2RAD
    lon = np.asarray(view.lon) * _DEG2RAD
    dlat = lat[j] - lat[i]
    dlon = lon[j] - lon[i]
    cavelat = np.cos(0.5 * (lat[i] + lat[j]))
    qdr = _RAD2DEG * np.fmod(np.arctan2(dlon * cavelat, dlat), 360.0)
    dist = _M2NM * (R_EARTH * np.sqrt(dlat * dlat + dlon * dlon * cavelat * cavelat)) * NM
    # Both sides: (i, j) and (j, i), with the same bearing and distance.
    own = np.concatenate([i, j])
    intr = np.concatenate([j, i])
    qdr2 = np.concatenate([qdr, qdr])
    dist2 = np.concatenate([dist, dist])
    qrad = np.radians(qdr2)
    dx = dist2 * np.sin(qrad)
    dy = dist2 * np.cos(qrad)
    trk = np.radians(np.asarray(view.trk))
    gs = np.asarray(view.gs)
    u = gs * np.sin(trk)
    v = gs * np.cos(trk)
    du = u[intr] - u[own]
    dv = v[intr] - v[own]
    dv2 = du * du + dv * dv
    dv2 = np.where(np.abs(dv2) < 1e-6, 1e-6, dv2)
    vrel = np.sqrt(dv2)
    tcpa = -(du * dx + dv * dy) / dv2
    dcpa2 = np.abs(dist2 * dist2 - tcpa * tcpa * dv2)
    r2 = rpz_m * rpz_m
    hor = dcpa2 < r2
    dtin = np.sqrt(np.maximum(0.0, r2 - dcpa2)) / vrel
    tinhor = np.where(hor, tcpa - dtin, 1e8)
    touthor = np.where(hor, tcpa + dtin, -1e8)
    alt = np.asarray(view.alt)
    vs = np.asarray(view.vs)
    dalt = alt[intr] - alt[own]
    dvs = vs[intr] - vs[own]
    dvs = np.where(np.abs(dvs) < 1e-6, 1e-6, dvs)
    with np.errstate(divide="ignore", invalid="ignore"):
        cross_hi = (dalt + hpz_m) / -dvs
        cross_lo = (dalt - hpz_m) / -dvs
    tin = np.maximum(np.minimum(cross_hi, cross_lo), tinhor)
    tout = np.minimum(np.maximum(cross_hi, cross_lo), touthor)
    conf = hor & (tin <= tout) & (tout > 0.0) & (tin < dtlook_s)
    k = np.flatnonzero(conf)
    k = k[np.lexsort((rank[intr[k]], rank[own[k]]))]  # BlueSky lists them row by row
    return DirectedConflicts(own[k], intr[k], qdr2[k], dist2[k], tcpa[k], tin[k])
