"""Conflict detection and loss-of-separation events: hand-built encounters with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.conflicts import SeparationVolume, closest_intruders
from aamsim.conflicts.events import encounter_type, track_speed
from aamsim.conflicts.pairs import slant_distances, statebased, volume_encounters
from aamsim.conflicts.service import search_pairs, traffic_snapshot
from aamsim.units import FT

DEG_PER_M = 1.0 / (6371000.0 * math.pi / 180.0)  # latitude degrees per metre (flat-earth sphere)


def encounter(lines: str, until: float = 300.0, volumes=None) -> Simulation:
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    service = sim.services.start().conflicts
    if volumes is not None:
        service.volumes = volumes
    sim.load_text(lines)
    sim.run_until(until)
    service.finish(sim)
    return sim


def counts(sim):
    s = sim.services.start().conflicts
    return s.count("nmac"), s.count("lowc")


def test_head_on_same_altitude_one_nmac_one_lowc():
    d = 4000 * DEG_PER_M
    sim = encounter(f"00:00:00.00>CRE A EC35 0 0 0 1000 100\n00:00:00.00>CRE B EC35 {d} 0 180 1000 100\n")
    assert counts(sim) == (1, 1)
    ev = [e for e in sim.services.start().conflicts.events if e.volume == "nmac"][0]
    assert ev.min_dist_m < 5.0
    # They meet after 2000 m at the same TAS; the NMAC sphere (150 m) is entered 75 m before.
    tas = float(sim.view.tas[0])
    assert ev.start_s == pytest.approx((2000 - 75) / tas, abs=0.05)
    assert ev.end_s == pytest.approx((2000 + 75) / tas, abs=0.05)
    assert ev.encounter == "head-on"
    assert track_speed(ev.vel1)[:2] == pytest.approx((0.0, tas)) and track_speed(ev.vel2)[0] == pytest.approx(180.0)


def test_parallel_tracks_300_m_apart_lowc_only():
    dlon = 300 * DEG_PER_M
    sim = encounter(f"00:00:00.00>CRE A EC35 0 0 0 1000 100\n00:00:00.00>CRE B EC35 0 {dlon} 0 1000 100\n",
                    until=120)
    assert counts(sim) == (0, 1)
    assert sim.services.start().conflicts.min_separation_m == pytest.approx(300.0, abs=0.5)


def test_minimum_separation_counts_a_graze_between_two_checks():
    # Head-on, 449.5 m apart laterally: the pair is inside LoWC (450 m) for 0.4 s,
    # from 38.11 to 38.52 s, between two checks (every second). The minimum
    # separation is the closest point of approach, not the distance at a check.
    d, offset = 4000 * DEG_PER_M, 449.5 * DEG_PER_M
    sim = encounter(f"00:00:00.00>CRE A EC35 0 0 0 1000 100\n00:00:00.00>CRE B EC35 {d} {offset} 180 1000 100\n",
                    until=100)
    (ev,) = [e for e in sim.services.start().conflicts.events if e.volume == "lowc"]
    assert math.floor(ev.start_s) == math.floor(ev.end_s) == 38
    assert ev.min_dist_m == pytest.approx(449.5, abs=0.01)
    assert sim.services.start().conflicts.min_separation_m == pytest.approx(449.5, abs=0.01)


def test_vertical_separation_200_m():
    # Crossing at one point with 200 m (656 ft) vertical separation. With the
    # paper's 3-D spheres that is no NMAC (150 m) but a LoWC (450 m); with a
    # detect-and-avoid cylinder of 137 m (450 ft) half-height it is neither.
    d = 3000 * DEG_PER_M
    text = (f"00:00:00.00>CRE A EC35 0 0 0 1000 100\n"
            f"00:00:00.00>CRE B EC35 {d} 0 180 {1000 + 200 / FT} 100\n")
    assert counts(encounter(text)) == (0, 1)
    cylinders = (SeparationVolume("nmac", 152.4, 30.5), SeparationVolume("lowc", 1219.2, 137.2))
    assert counts(encounter(text, volumes=cylinders)) == (0, 0)


def test_in_trail_overtake_twice_is_two_events():
    # B starts 1 km ahead on the same track. A (faster) overtakes B, then slows
    # down and B overtakes it back: the pair enters and leaves LoWC twice.
    d = 1000 * DEG_PER_M
    sim = encounter(
        "00:00:00.00>CRE A EC35 0 0 0 1000 120\n"
        f"00:00:00.00>CRE B EC35 {d} 0 0 1000 60\n"
        "00:02:00.00>SPD A 20\n",
        until=600,
    )
    lowc = [e for e in sim.services.start().conflicts.events if e.volume == "lowc"]
    assert len(lowc) == 2
    assert all(not e.active for e in lowc)
    assert lowc[0].end_s < lowc[1].start_s
    assert counts(sim)[0] == 2  # they also pass within 150 m (same track) twice
    assert {e.encounter for e in lowc} == {"same-direction"}


def test_three_aircraft_cluster_three_pairs():
    d = 3000 * DEG_PER_M
    c = math.cos(math.radians(30))
    sim = encounter(
        f"00:00:00.00>CRE A EC35 {-d} 0 0 1000 100\n"
        f"00:00:00.00>CRE B EC35 {d * 0.5} {d * c} 240 1000 100\n"
        f"00:00:00.00>CRE C EC35 {d * 0.5} {-d * c} 120 1000 100\n"
    )
    nmac, lowc = counts(sim)
    assert (nmac, lowc) == (3, 3)
    pairs = {(e.ac1, e.ac2) for e in sim.services.start().conflicts.events if e.volume == "lowc"}
    assert pairs == {("A", "B"), ("A", "C"), ("B", "C")}
    assert {e.encounter for e in sim.services.start().conflicts.events} == {"crossing"}  # tracks 120 deg apart


def test_deleted_aircraft_closes_only_its_own_events():
    # A and B head-on (4 km, 2 x 100 kt CAS, 52.2 m/s TAS): inside the NMAC sphere from 36.9 s,
    # they would meet at 38.3 s, but A is deleted at 37.7 s, between two checks. C and D fly parallel 300 m
    # apart: one LoWC event that A's deletion must leave open.
    d = 4000 * DEG_PER_M
    dlon = 300 * DEG_PER_M
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    service = sim.services.start().conflicts
    sim.load_text(f"00:00:00.00>CRE A EC35 0 0 0 1000 100\n00:00:00.00>CRE B EC35 {d} 0 180 1000 100\n"
                  f"00:00:00.00>CRE C EC35 0.5 0 0 1000 100\n00:00:00.00>CRE D EC35 0.5 {dlon} 0 1000 100\n"
                  "00:00:37.70>DEL A\n")
    sim.run_until(60.0)
    tas = float(sim.view.tas[0])
    ab = [e for e in service.events if e.volume == "nmac"]
    assert [(e.ac1, e.ac2) for e in ab] == [("A", "B")]
    assert 4000 - 2 * tas * 37.0 < 150 and 4000 - 2 * tas * 38.0 > 0  # inside NMAC at 37 s, not met at 38 s
    assert ab[0].end_s == pytest.approx(37.7, abs=1e-6)
    assert ab[0].min_dist_m == pytest.approx(4000 - 2 * tas * 37.7, abs=1.0)  # closest at the deletion
    cd = [e for e in service.events if (e.ac1, e.ac2) == ("C", "D")]
    assert len(cd) == 1 and cd[0].volume == "lowc" and cd[0].active
    assert service.in_volume_now("lowc") == {"C", "D"}


def test_a_paused_service_records_nothing_and_its_first_check_after_looks_back_one_interval():
    """``paused`` (a single-agent episode before its ego exists): no events while paused; afterwards the
    checks find what they would have found, looking back to the last (paused) check, not further."""
    d = 4000 * DEG_PER_M
    dlon = 300 * DEG_PER_M
    text = (f"00:00:00.00>CRE A EC35 0 0 0 1000 100\n00:00:00.00>CRE B EC35 {d} 0 180 1000 100\n"
            f"00:00:00.00>CRE C EC35 0.5 0 0 1000 100\n00:00:00.00>CRE D EC35 0.5 {dlon} 0 1000 100\n"
            "00:00:00.00>CRE E EC35 0.5 0.001 0 1000 100\n00:00:15.00>DEL E\n")
    runs = {}
    for paused in (False, True):
        sim = Simulation(seed=1, use_bluesky_navdata=False)
        service = sim.services.start().conflicts
        sim.load_text(text)
        service.paused = paused
        sim.run_until(20.0)
        if paused:
            # C, D and E were inside LoWC, E deleted: nothing recorded, nothing open.
            assert service.events == [] and service.in_volume_now("lowc") == set()
        service.paused = False
        sim.run_until(60.0)
        service.finish(sim)
        runs[paused] = {(e.ac1, e.ac2, e.volume): e for e in service.events}
    full, after = runs[False], runs[True]
    # A and B meet after 20 s: the same events, to the bit.
    for key in (("A", "B", "nmac"), ("A", "B", "lowc")):
        assert (after[key].start_s, after[key].end_s, after[key].min_dist_m) == \
            (full[key].start_s, full[key].end_s, full[key].min_dist_m)
    # C and D flew 300 m apart all along: recorded from the first check after the pause, which looks back
    # one interval (to the paused check at 20 s), not to their creation.
    assert full[("C", "D", "lowc")].start_s == 0.0
    assert after[("C", "D", "lowc")].start_s == pytest.approx(20.0)
    # E, flying beside C 111 m away and deleted during the pause: its events exist only in the full run.
    with_e = {k for k in full if "E" in k[:2]}
    assert ("C", "E", "nmac") in with_e and set(full) - set(after) == with_e and not set(after) - set(full)


def test_encounter_types():
    east, north = (70.0, 0.0, 0.0), (0.0, 70.0, 0.0)
    assert encounter_type(north, north) == "same-direction"
    assert encounter_type(north, (0.0, -60.0, 0.0)) == "head-on"
    assert encounter_type(north, east) == "crossing"
    assert encounter_type(north, (0.0, 0.5, 0.0)) == "hover"
    assert encounter_type(north, (0.0, 60.0, 2.0)) == "vertical"
    assert encounter_type(north, (math.nan,) * 3) == ""
    assert track_speed((-1.0, 0.0, 0.5)) == pytest.approx((270.0, 1.0, 0.5))


def test_short_encounter_between_checks_is_not_missed():
    # Two fast aircraft crossing at right angles with a 10 m miss: inside the 150 m
    # sphere for well under the 1 s check interval.
    d = 1000 * DEG_PER_M
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    service = sim.services.start().conflicts
    sim.settings.cd_interval_s = 1.0
    sim.stack("CRE A A320 0 0 0 1000 250")
    sim.stack(f"CRE B A320 {d * 0.99} {-d} 90 1000 250")
    sim.run_until(20.0)
    service.finish(sim)
    nmac = [e for e in service.events if e.volume == "nmac"]
    assert len(nmac) == 1


def test_statebased_cd_flags_and_switch():
    d = 20000 * DEG_PER_M
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    service = sim.services.start().conflicts
    sim.stack(f"CRE A EC35 0 0 0 1000 100; CRE B EC35 {d} 0 180 1000 100; CRE C EC35 0 1 0 1000 100")
    sim.run_until(2.0)
    assert service.state is None  # ASAS is off by default, as in BlueSky
    sim.stack("ASAS ON; ZONER 0.243; DTLOOK 300")
    sim.run_until(4.0)
    st_ = service.state
    assert st_.pairs == (("A", "B"),)
    assert list(st_.inconf) == [True, True, False]
    # tcpa: 20 km closing at 2 x TAS, minus the 4 s flown
    tas = float(sim.view.tas[0])
    assert st_.tcpa_s[0] == pytest.approx((20000 - 4 * 2 * tas) / (2 * tas), rel=1e-3)
    sim.stack("DTLOOK 60")
    sim.run_until(6.0)
    assert service.state.pairs == ()  # 190 s away: beyond a 60 s look-ahead
    sim.stack("ASAS OFF")
    sim.run_until(8.0)
    assert service.state is None


def test_closest_intruder_distance():
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    d = 1000 * DEG_PER_M
    sim.stack(f"CRE A EC35 0 0 0 1000 100; CRE B EC35 {d} 0 0 1000 100; CRE C EC35 0 1 0 1000 100")
    dist, idx = closest_intruders(sim, 3000)
    assert dist[0] == pytest.approx(1000, abs=0.01) and idx[0] == 1 and idx[1] == 0
    assert math.isinf(dist[2]) and idx[2] == -1


# ----------------------------------------------------- brute force equivalence
traffic_strategy = st.lists(
    st.tuples(st.floats(-0.15, 0.15), st.floats(-0.15, 0.15), st.floats(0, 800), st.floats(0, 360),
              st.floats(0, 80), st.floats(-8, 8)),
    min_size=0, max_size=60)


def _sim_with(traffic) -> Simulation:
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    for k, (lat, lon, alt, trk, gs, vs) in enumerate(traffic):
        i = sim.create_aircraft(f"X{k}", "EC35", 40.7 + lat, -74 + lon, trk, alt)
        F = sim._traffic.F
        from aamsim.traffic import fields as f
        F[f.GS, i] = gs
        F[f.TRK, i] = trk
        F[f.GSEAST, i] = gs * math.sin(math.radians(trk))
        F[f.GSNORTH, i] = gs * math.cos(math.radians(trk))
        F[f.VS, i] = vs
    return sim


def _all_pairs(n):
    pi, pj = np.triu_indices(n, 1)
    return pi.astype(np.int64), pj.astype(np.int64)


@settings(max_examples=60, deadline=None)
@given(traffic_strategy, st.floats(100, 3000), st.floats(0, 300))
def test_grid_statebased_equals_brute_force(traffic, rpz, tlook):
    sim = _sim_with(traffic)
    s = traffic_snapshot(sim)
    n = len(s.ids)
    ci, cj = search_pairs(s, np.zeros(n), np.full(n, tlook), rpz)
    ai, aj = _all_pairs(n)
    conf_c = statebased(s.lat, s.lon, s.alt, s.u, s.v, s.w, ci, cj, rpz, 150.0, tlook)[0]
    conf_a = statebased(s.lat, s.lon, s.alt, s.u, s.v, s.w, ai, aj, rpz, 150.0, tlook)[0]
    assert set(zip(ci[conf_c].tolist(), cj[conf_c].tolist())) == set(zip(ai[conf_a].tolist(), aj[conf_a].tolist()))
    assert len(set(zip(ci.tolist(), cj.tolist()))) == len(ci)  # each pair once


@settings(max_examples=60, deadline=None)
@given(traffic_strategy, st.floats(50, 2000), st.floats(0, 5), st.booleans())
def test_grid_volumes_and_closest_equal_brute_force(traffic, radius, lookback, cylinder):
    sim = _sim_with(traffic)
    s = traffic_snapshot(sim)
    n = len(s.ids)
    back = np.full(n, lookback)
    ci, cj = search_pairs(s, -back, np.zeros(n), radius)
    ai, aj = _all_pairs(n)
    ins_c = volume_encounters(s.lat, s.lon, s.alt, s.u, s.v, s.w, back, ci, cj, cylinder, radius, 100.0)[0]
    ins_a = volume_encounters(s.lat, s.lon, s.alt, s.u, s.v, s.w, back, ai, aj, cylinder, radius, 100.0)[0]
    assert set(zip(ci[ins_c].tolist(), cj[ins_c].tolist())) == set(zip(ai[ins_a].tolist(), aj[ins_a].tolist()))
    dist, _ = closest_intruders(sim, radius)
    brute = np.full(n, math.inf)
    d = slant_distances(s.lat, s.lon, s.alt, ai, aj)
    for a, b, dd in zip(ai, aj, d):
        if dd <= radius:
            brute[a] = min(brute[a], dd)
            brute[b] = min(brute[b], dd)
    assert np.array_equal(dist, brute)


@settings(max_examples=60, deadline=None)
@given(traffic_strategy, st.floats(100, 3000), st.floats(0, 300), st.floats(0, 5), st.booleans(),
       st.sampled_from([0, 1, 100000]))
def test_fused_check_equals_brute_force(traffic, rpz, tlook, lookback, cylinder, cap_hint):
    """The one-pass check (what the service runs) against every pair tested one by one."""
    from aamsim.conflicts.fused import detect_all
    from aamsim.conflicts.service import _SNAPSHOT_ROWS
    from aamsim.units import R_EARTH

    sim = _sim_with(traffic)
    s = traffic_snapshot(sim)
    n = len(s.ids)
    back = np.full(n, lookback)
    radii, half = np.array([150.0, 450.0]), np.array([60.0, 150.0])
    cyl = np.array([cylinder, False])
    out = detect_all(sim._traffic.F, n, _SNAPSHOT_ROWS, R_EARTH, back, True, rpz, 150.0, tlook, radii, cyl, half,
                     1000.0, cap_hint)
    ci, cj, tcpa, li, lj = out.conflict_i, out.conflict_j, out.tcpa, out.los_i, out.los_j
    inconf, tcpamax, eq, ei, ej = out.inconf, out.tcpamax, out.event_volume, out.event_i, out.event_j
    closest = out.closest
    ai, aj = _all_pairs(n)
    conf, tcpa_a, _, _, _, los = statebased(s.lat, s.lon, s.alt, s.u, s.v, s.w, ai, aj, rpz, 150.0, tlook)
    brute = dict(zip(zip(ai[conf].tolist(), aj[conf].tolist()), tcpa_a[conf].tolist()))
    assert dict(zip(zip(ci.tolist(), cj.tolist()), tcpa.tolist())) == pytest.approx(brute)
    assert len(ci) == len(brute)
    assert set(zip(li.tolist(), lj.tolist())) == set(zip(ai[los].tolist(), aj[los].tolist()))
    assert set(np.flatnonzero(inconf).tolist()) == set(ai[conf].tolist()) | set(aj[conf].tolist())
    for k in range(n):
        mine = [t for (a, b), t in brute.items() if k in (a, b)]
        assert tcpamax[k] == pytest.approx(max(mine + [0.0]))  # BlueSky's tcpamax starts at 0
    for q in range(2):
        ins = volume_encounters(s.lat, s.lon, s.alt, s.u, s.v, s.w, back, ai, aj, bool(cyl[q]), radii[q], half[q])[0]
        got = set(zip(ei[eq == q].tolist(), ej[eq == q].tolist()))
        assert got == set(zip(ai[ins].tolist(), aj[ins].tolist()))
    d = slant_distances(s.lat, s.lon, s.alt, ai, aj)
    brute_closest = np.full(n, math.inf)
    for a, b, dd in zip(ai, aj, d):
        if dd <= 1000.0:
            brute_closest[a] = min(brute_closest[a], dd)
            brute_closest[b] = min(brute_closest[b], dd)
    np.testing.assert_allclose(closest, brute_closest, rtol=1e-9, atol=1e-6)


def test_metrics_are_deterministic():
    def go():
        sim = Simulation(seed=5, use_bluesky_navdata=False)
        m = sim.services.start().metrics
        sim.load_text("00:00:00.00>MCRE 40 EC35 1500 100\n")
        sim.settings.mcre_area = (40.6, -74.1, 40.8, -73.9)
        sim.run_until(120.0)
        return m.compute(sim)
    assert go() == go()


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 40)), max_size=200),
       st.lists(st.tuples(st.integers(0, 40), st.integers(0, 40)), max_size=200), st.integers(0, 2**31 - 1000))
def test_new_conflict_pairs_counted_against_the_previous_check(prev_pairs, pairs, serial0):
    """A pair is new when its two aircraft (by serial, in either slot order) were not a pair before."""
    from aamsim.conflicts.fused import new_pair_count

    serial = np.arange(serial0, serial0 + 41, dtype=np.int64)[::-1].copy()  # slots map to large serials
    prev_pairs = list({(min(a, b), max(a, b)) for a, b in prev_pairs if a != b})
    pairs = list({(min(a, b), max(a, b)) for a, b in pairs if a != b})
    pi, pj = (np.array([p[k] for p in prev_pairs], dtype=np.int64) for k in (0, 1))
    _, previous = new_pair_count(serial, pi, pj, np.empty(0, dtype=np.int64))
    ci, cj = (np.array([p[k] for p in pairs], dtype=np.int64) for k in (0, 1))
    new, keys = new_pair_count(serial, cj, ci, previous)  # slot order swapped: the same pairs
    assert new == len(set(pairs) - set(prev_pairs))
    assert len(keys) == len(pairs) and len(set(keys.tolist())) == len(pairs)


def test_conflict_pairs_total_counts_each_new_conflict_once():
    # Two head-on pairs far apart: each is in conflict for many checks but counts once.
    d = 8000 * DEG_PER_M
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    service = sim.services.start().conflicts
    sim.stack("ASAS ON; ZONER 0.243; DTLOOK 60")
    sim.load_text(f"00:00:00.00>CRE A EC35 0 0 0 1000 100\n00:00:00.00>CRE B EC35 {d} 0 180 1000 100\n"
                  f"00:00:00.00>CRE C EC35 0 1 0 1000 100\n00:00:00.00>CRE D EC35 {d} 1 180 1000 100\n")
    sim.run_until(5.0)
    assert service.conflict_pairs_total == 0  # 8 km apart, 104 m/s closing: LoS in 72 s, conflict from 12 s
    sim.run_until(20.0)
    assert service.conflict_pairs_total == 2
    sim.run_until(150.0)
    assert service.conflict_pairs_total == 2


@pytest.mark.parametrize("rel", [-1e-6, -1e-9, -1e-12, 0.0, 1e-12, 1e-9, 1e-6])
def test_fused_check_agrees_with_statebased_at_the_zone_edge(rel):
    """A pair whose closest point lies on the protected zone's edge (to rounding) gets
    the same verdict from the one-pass check (with its division-free pre-test) as from
    BlueSky's formula pair by pair."""
    from aamsim.conflicts.fused import detect_all
    from aamsim.conflicts.service import _SNAPSHOT_ROWS
    from aamsim.units import R_EARTH

    # Head-on, 2.2 km apart along track, about 450 m apart across; and a crossing pair.
    sim = _sim_with([(0.0, 0.0, 300.0, 10.0, 40.0, 0.0), (0.02, 0.0055, 300.0, 190.0, 40.0, 0.0),
                     (0.05, 0.05, 300.0, 90.0, 30.0, 0.0), (0.06, 0.07, 300.0, 200.0, 50.0, 0.0)])
    s = traffic_snapshot(sim)
    ai, aj = _all_pairs(4)
    _, _, dcpa, _, _, _ = statebased(s.lat, s.lon, s.alt, s.u, s.v, s.w, ai, aj, 1e5, 150.0, 1e6)
    lo, hi = np.array([150.0, 450.0]), np.zeros(2)
    for k in (0, 5):  # the head-on pair (0, 1) and the crossing pair (2, 3)
        rpz = float(dcpa[k]) * (1.0 + rel)
        conf = statebased(s.lat, s.lon, s.alt, s.u, s.v, s.w, ai, aj, rpz, 150.0, 600.0)[0]
        found = detect_all(sim._traffic.F, 4, _SNAPSHOT_ROWS, R_EARTH, np.zeros(4), True, rpz, 150.0, 600.0, lo,
                           np.zeros(2, bool), hi, 1000.0, 0)
        ci, cj = found.conflict_i, found.conflict_j
        assert set(zip(ci.tolist(), cj.tolist())) == set(zip(ai[conf].tolist(), aj[conf].tolist()))
