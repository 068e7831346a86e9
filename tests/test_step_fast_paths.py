"""Fast paths of a decision step (issue 31, round three): each gives exactly what the slower code it replaced gave.

The vector environments' worlds must stay bit for bit their own simulations, so every shortcut taken per
step is checked here against the plain computation it stands for: the event log's interval query, the
one-call pair search, the world set's joint conditional commands and the advisory counts; and the
corridor use case's route arrays against a per-aircraft reference (a one-write version of them measured
slower in one process, 52 against 32 microseconds at 17 aircraft, and was not kept; the test pins what
any faster version must give).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.conflicts import events as events_module
from aamsim.conflicts.events import EventLog
from aamsim.conflicts.pairs import slant_distances
from aamsim.conflicts.service import pairs_within, search_pairs, traffic_snapshot
from aamsim.errors import SourceRef
from aamsim.metrics import record_advisories, record_advisory
from aamsim.traffic.conditions import Condition
from aamsim.traffic.kernel import COND_DIST
from aamsim.traffic.pool import TrafficPool
from rlbridge.core import EpisodeCore


# ----------------------------------------------------------------------------- route arrays
def _route_arrays_reference(sim: Simulation, nw: int, slots: list[int]) -> tuple[np.ndarray, ...]:
    """The corridor use case's destination and next waypoints, one value at a time (the code before)."""
    t, view = sim._traffic, sim.view
    n = t.n
    dest_lat, dest_lon = np.full(n, np.nan), np.full(n, np.nan)
    wlat, wlon = np.full((n, nw), np.nan), np.full((n, nw), np.nan)
    for s in slots:
        route, rec = t.routes[s], t.flights[s]
        wps = route.waypoints
        if wps:
            if rec.destination and not math.isnan(rec.dest_lat):
                dest_lat[s], dest_lon[s] = rec.dest_lat, rec.dest_lon
            else:
                dest_lat[s], dest_lon[s] = wps[-1].lat, wps[-1].lon
            start = route.iactwp if view.lnav[s] and route.iactwp >= 0 else len(wps)
            for j in range(nw):
                k = start + j
                if k < len(wps):
                    wlat[s, j], wlon[s, j] = wps[k].lat, wps[k].lon
                else:
                    wlat[s, j], wlon[s, j] = dest_lat[s], dest_lon[s]
        else:
            dest_lat[s], dest_lon[s] = view.lat[s], view.lon[s]
            wlat[s, :], wlon[s, :] = view.lat[s], view.lon[s]
    return dest_lat, dest_lon, wlat, wlon


@pytest.mark.parametrize("nw", [0, 2, 3])
def test_route_arrays_are_the_per_aircraft_reference(nw):
    core = EpisodeCore("nyc_train_100.scn", "corridor_sa", {"decision_interval_s": 5.0, "n_wpt": nw})
    core.reset(seed=2)
    for _ in range(60):
        core.step({})
    sim = core.sim
    # An aircraft without a route, one whose LNAV is off, and one past the end of its route's waypoints.
    sim.stack("CRE NOROUTE EC35 40.70 -74.00 90 1000 60")
    ids = list(sim.view.ids)
    sim.stack(f"LNAV {ids[0]} OFF")
    assert sim.view.n > 10
    uc = core.usecase
    n = sim.view.n
    rng = np.random.default_rng(0)
    for slots in (None, np.array([n - 1], dtype=np.int64), np.sort(rng.choice(n, 7, replace=False)),
                  np.arange(n, dtype=np.int64)):
        which = list(range(n)) if slots is None else slots.tolist()
        ddest, wlat, wlon, dest_lat, dest_lon = uc._route_arrays(sim, slots)
        ref = _route_arrays_reference(sim, nw, which)
        for got, want in zip((dest_lat, dest_lon, wlat, wlon), ref):
            assert np.array_equal(got[which], want[which], equal_nan=True)
        others = np.setdiff1d(np.arange(n), which)
        assert np.isnan(dest_lat[others]).all() and np.isnan(ddest[others]).all()
        assert np.isfinite(ddest[which]).all()
    noroute = sim.view.slot("NOROUTE")
    _, wlat, wlon, dest_lat, dest_lon = uc._route_arrays(sim, None)
    assert dest_lat[noroute] == sim.view.lat[noroute] and (wlon[noroute] == sim.view.lon[noroute]).all()


# ------------------------------------------------------------------------- interval query
@st.composite
def _logs(draw):
    """An event log with rows ended before, at, after a query time or still open (NaN), distances with ties."""
    n = draw(st.integers(0, 50))
    log = EventLog("lowc")
    log._reserve(n)
    names = [f"AC{k}" for k in range(8)]
    for r in range(n):
        a, b = draw(st.lists(st.integers(0, 7), min_size=2, max_size=2, unique=True))
        log.ac1.append(names[a])
        log.ac2.append(names[b])
        log.serial1[r], log.serial2[r] = a, b
        log.end[r] = draw(st.sampled_from([math.nan, 5.0, 10.0 - 5e-10, 10.0, 12.0]))
        log.dmin[r] = draw(st.sampled_from([100.0, 150.0, 200.0, 375.5, math.nan]))
    log.n = n
    log._cursor = draw(st.integers(0, n))
    return log


@settings(max_examples=150, deadline=None)
@given(log=_logs(), t0=st.sampled_from([0.0, 5.0, 10.0, 11.0, 20.0]))
def test_involved_since_in_python_is_the_array_pass(log, t0):
    import copy

    few = copy.deepcopy(log)
    events_module._FEW_ROWS, saved = 0, events_module._FEW_ROWS  # the array pass for every size
    try:
        want = log.involved_since(t0)
    finally:
        events_module._FEW_ROWS = saved
    got = few.involved_since(t0)
    assert repr(list(got.items())) == repr(list(want.items()))  # same callsigns, distances (NaN too) and order
    assert few._cursor == log._cursor


def test_involved_since_by_hand_in_python():
    """Three events (the by-hand case of tests/test_bridge_limits.py), answered by the Python path."""
    log = EventLog("lowc")
    log.update(10.0, 9.0, ["A", "B", "C"], np.array([0, 1, 0]), np.array([1, 2, 2]), np.array([0, 1, 2]),
               np.array([0, 1, 2]), np.zeros(3), np.array([0.0, -1.0, 0.0]), np.array([300.0, 200.0, 400.0]),
               np.zeros(3), np.zeros((3, 12)), None)
    assert log.n <= events_module._FEW_ROWS
    assert list(log.involved_since(8.5).items()) == [("A", 300.0), ("B", 200.0), ("C", 200.0)]
    assert list(log.involved_since(9.5).items()) == [("A", 300.0), ("B", 300.0), ("C", 400.0)]


# ----------------------------------------------------------------------------- pair search
@settings(max_examples=40, deadline=None)
@given(n=st.integers(0, 40), seed=st.integers(0, 2**16), radius=st.sampled_from([50.0, 3000.0, 10000.0]))
def test_pairs_within_in_one_call_is_snapshot_search_and_distances(n, seed, radius):
    rng = np.random.default_rng(seed)
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    for k in range(n):
        sim.stack(f"CRE P{k} EC35 {40.7 + rng.uniform(-0.05, 0.05):.6f} {-74.0 + rng.uniform(-0.05, 0.05):.6f} "
                  f"{rng.uniform(0, 360):.1f} {rng.uniform(500, 1500):.0f} {rng.uniform(0, 120):.0f}")
    s = traffic_snapshot(sim)
    zeros = np.zeros(len(s.ids))
    pi, pj = search_pairs(s, zeros, zeros, radius)
    d = slant_distances(s.lat, s.lon, s.alt, pi, pj)
    gi, gj, gd = pairs_within(sim, radius)
    assert np.array_equal(gi, pi) and np.array_equal(gj, pj) and np.array_equal(gd, d)


# ------------------------------------------------------------------- joint conditional commands
def _world(pool: TrafficPool, w: int, n: int) -> tuple[Simulation, list[str]]:
    sim = Simulation(seed=w, use_bluesky_navdata=False, traffic=pool.new_traffic(w))
    sim.services.start()
    ids = [f"W{w}A{k}" for k in range(n)]
    for k, acid in enumerate(ids):
        sim.stack(f"CRE {acid} EC35 40.{70 + k} -74.0 90 1000 60")
    return sim, ids


def _condition(acid: str, target_m: float) -> Condition:
    return Condition(acid, COND_DIST, target_m, math.inf, f"SPD {acid} 20", SourceRef("<test>"), 40.7, -73.9)


def test_joint_conditions_are_reused_until_a_world_changes_them():
    pool = TrafficPool(2)
    worlds = [_world(pool, w, 3) for w in range(2)]
    for (sim, ids) in worlds:
        sim.conditions.add(_condition(ids[0], 500.0))
    joint = pool._joint_conditions

    def parts():
        return [(sim.conditions, pool.members[w], w * pool.block) for w, (sim, _) in enumerate(worlds)]

    first, own = joint.arrays(parts())
    assert len(first[0]) == 2 and np.shares_memory(own[0][6], first[6])
    first[6][:] = True  # as the kernel leaves them when conditions fired
    again, own2 = joint.arrays(parts())
    assert again is first and not again[6].any()  # the same joint arrays, fired flags cleared for all
    assert all(a is b for a, b in zip(own, own2))
    # A condition added in world 1: its arrays are rebuilt, so the joint ones are too.
    worlds[1][0].conditions.add(_condition(worlds[1][1][2], 800.0))
    third, _ = joint.arrays(parts())
    assert third is not first and len(third[0]) == 3
    assert third[0].tolist() == [worlds[0][0].view.slot("W0A0"), pool.block + worlds[1][0].view.slot("W1A0"),
                                 pool.block + worlds[1][0].view.slot("W1A2")]
    assert third[2].tolist() == [500.0, 500.0, 800.0]
    # An aircraft created in world 0 moves no slot but changes its layout: rebuilt again, same values.
    worlds[0][0].stack("CRE W0A9 EC35 40.9 -74.0 90 1000 60")
    fourth, _ = joint.arrays(parts())
    assert fourth is not third and fourth[0].tolist() == third[0].tolist()
    # A world without conditions in between: no arrays for it, the others' still joint.
    mixed = [None, parts()[1]]
    fifth, own5 = joint.arrays(mixed)
    assert own5[0] is None and len(fifth[0]) == 2


# ------------------------------------------------------------------------------ advisories
def test_record_advisories_by_slot_counts_as_record_advisory_by_callsign():
    def make():
        sim = Simulation(seed=0, use_bluesky_navdata=False)
        for k in range(4):
            sim.stack(f"CRE A{k} EC35 40.7 -74.{k} 90 1000 60")
        sim.run_until(12.4)
        return sim

    one, many = make(), make()
    given_ = [("A2", "decelerate"), ("A0", "hold"), ("A3", "accelerate"), ("A2", "accelerate")]
    for acid, action in given_:
        record_advisory(one, acid, action)
    record_advisories(many, [many.view.slot(a) for a, _ in given_], [action for _, action in given_])
    got = [(f.advisories, f.last_advisory) for f in many._traffic.flights]
    assert got == [(f.advisories, f.last_advisory) for f in one._traffic.flights]
    assert got == [(0, ""), (0, ""), (2, "accelerate at 12 s"), (1, "accelerate at 12 s")]
