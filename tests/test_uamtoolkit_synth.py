"""The synthetic UAMToolkit: demand model, fleet dispatch, lane assignment, windows."""

from __future__ import annotations

import io
import itertools
from collections import defaultdict

import numpy as np
import pytest
from uam_helpers import run_module

from uamtoolkit_import.demand import DemandModel, generate_requests, hourly_rates
from uamtoolkit_import.lanes import LaneBook, LaneUse, timed_legs
from uamtoolkit_import.netfile import nyc_network
from uamtoolkit_import.scenarios import WindowNotFound, find_window
from uamtoolkit_import.schedule import parse_schedule, write_schedule
from uamtoolkit_import.synth import SynthConfig, synthesize

NET = nyc_network()


@pytest.fixture(scope="module")
def day():
    return synthesize(NET, SynthConfig(fleet_size=40, seed=11, demand=DemandModel(daily_requests=2000)))


# -------------------------------------------------------------------- demand
def test_rates_sum_to_the_daily_volume_and_follow_the_profile():
    model = DemandModel(daily_requests=5000)
    rates = hourly_rates(NET, model)
    assert rates.shape == (24, 29, 29)
    assert rates.sum() == pytest.approx(5000)
    per_hour = rates.sum(axis=(1, 2))
    assert per_hour.argmin() == 4 and per_hour[8] > per_hour[4] * 5  # night trough, morning peak
    assert np.all(np.diag(rates.sum(axis=0)) == 0)


def test_short_trips_are_left_to_ground_transport():
    rates = hourly_rates(NET, DemandModel()).sum(axis=0)
    ids = list(NET.vertiports)
    for i, j in itertools.permutations(range(len(ids)), 2):
        if NET.leg_length_m(ids[i], ids[j]) < 5000:
            assert rates[i, j] == 0


def test_commuter_bias_into_the_cbd_in_the_morning_out_in_the_evening():
    rates = hourly_rates(NET, DemandModel())
    ids = list(NET.vertiports)
    jfk, dmh = ids.index("JFK"), ids.index("DMH")
    assert rates[8, jfk, dmh] > 1.5 * rates[8, dmh, jfk]
    assert rates[18, dmh, jfk] > 1.5 * rates[18, jfk, dmh]


def test_demand_is_deterministic_for_a_seed():
    model = DemandModel(daily_requests=800)
    a = generate_requests(NET, model, np.random.default_rng(3))
    b = generate_requests(NET, model, np.random.default_rng(3))
    c = generate_requests(NET, model, np.random.default_rng(4))
    assert a == b and a != c
    assert all(x.t_s <= y.t_s for x, y in itertools.pairwise(a))
    assert all(1 <= r.passengers <= 4 and 0 <= r.cargo_kg <= 80 for r in a)


# ---------------------------------------------------------------------- lanes
def test_a_lane_per_od_pair_is_not_reused_while_in_use():
    book = LaneBook(margin_s=0.0)
    lanes = (500.0, 1200.0, 1900.0)

    def fly(o, d, t, arr):
        legs = ((o, "X", t, t + 1), ("X", d, t + 1, arr))
        lane = book.choose(o, d, lanes, legs, t)
        book.occupy(LaneUse(lane, o, d, t, arr, legs))
        return lane

    assert fly("A", "B", 0, 100) == 500.0
    assert fly("A", "B", 10, 100) == 1200.0  # same pair, same direction
    assert fly("B", "A", 20, 100) == 1900.0  # same pair, other direction
    assert fly("C", "D", 20, 100) == 500.0  # another pair is not constrained by A-B
    assert fly("A", "B", 150, 250) == 500.0  # all A-B flights have landed


def test_head_on_overlaps_between_pairs_are_refused():
    book = LaneBook(margin_s=30.0)
    lanes = (500.0, 1200.0)
    first = timed_legs(["A", "N1", "N2", "B"], [1000, 3000, 1000], 50.0, 0.0)
    book.occupy(LaneUse(500.0, "A", "B", 0.0, 100.0, first))
    # C -> D flies N2 -> N1 (the reverse of A -> B) while A -> B is on it: not lane 500.
    opposite = timed_legs(["C", "N2", "N1", "D"], [500, 3000, 500], 50.0, 10.0)
    assert book.choose("C", "D", lanes, opposite, 10.0) == 1200.0
    # Same direction is fine (overtaking stays possible, head-on does not).
    same = timed_legs(["C", "N1", "N2", "D"], [500, 3000, 500], 50.0, 10.0)
    assert book.choose("C", "D", lanes, same, 10.0) == 500.0
    # Long after A -> B has flown N1-N2, the reverse is free again.
    later = timed_legs(["C", "N2", "N1", "D"], [500, 3000, 500], 50.0, 200.0)
    assert book.choose("C", "D", lanes, later, 200.0) == 500.0
    # When every lane has an opposite-direction flight, the flight has to wait.
    book.occupy(LaneUse(1200.0, "C", "D", 10.0, 90.0, same))
    assert book.choose("E", "F", lanes, opposite, 10.0) is None


# ---------------------------------------------------------------------- fleet
def test_fleet_starts_evenly_spread_and_flights_chain(day):
    by_tail = defaultdict(list)
    for f in day.flights:
        by_tail[f.tail_id].append(f)
    start = {tail: fl[0].origin for tail, fl in by_tail.items()}
    counts = defaultdict(int)
    for tail, vp in start.items():
        counts[vp] += 1
        assert list(NET.vertiports).index(vp) == (int(tail[1:]) - 1) % 29  # aircraft k at vertiport k mod 29
    assert max(counts.values()) <= 2  # 40 aircraft over 29 vertiports
    for flights in by_tail.values():
        assert len({f.cruise_speed_kts for f in flights}) == 1  # a speed per vehicle
        for a, b in itertools.pairwise(flights):
            assert b.origin == a.destination  # no empty repositioning
            assert b.departure_s >= a.arrival_s + 600  # turnaround
    speeds = [f.cruise_speed_kts for f in day.flights]
    assert 87 <= min(speeds) and max(speeds) <= 150
    assert day.served + day.lost == day.requests


def test_no_two_airborne_flights_of_a_pair_share_a_lane_in_opposite_directions(day):
    flights = sorted(day.flights, key=lambda f: f.departure_s)
    for a, b in itertools.combinations(flights, 2):
        if b.departure_s >= a.arrival_s:
            continue
        if {a.origin, a.destination} == {b.origin, b.destination} and a.origin != b.origin:
            assert a.cruise_alt_ft != b.cruise_alt_ft


def test_routes_are_shortest_paths_and_times_follow_speed(day):
    for f in day.flights[:200]:
        path = [f.origin, *f.route, f.destination]
        assert path == NET.shortest_path(f.origin, f.destination)
        assert f.cruise_alt_ft in NET.route_lanes(path)
        expected = NET.path_length_m(path) / (f.cruise_speed_kts * 0.514444)
        assert f.arrival_s - f.departure_s == pytest.approx(expected, abs=1.0)


def test_schedule_written_by_synth_reads_back_without_errors(day):
    buf = io.StringIO()
    write_schedule(day.flights, buf)
    sched = parse_schedule(io.StringIO(buf.getvalue()), NET, "synth.csv")
    assert sched.errors == [] and len(sched.flights) == day.served


def test_same_seed_same_schedule():
    cfg = SynthConfig(fleet_size=10, seed=5, demand=DemandModel(daily_requests=300))
    assert synthesize(NET, cfg).flights == synthesize(NET, cfg).flights
    other = SynthConfig(fleet_size=10, seed=6, demand=DemandModel(daily_requests=300))
    assert synthesize(NET, other).flights != synthesize(NET, cfg).flights


def test_python_m_synth_writes_a_schedule(tmp_path):
    out = tmp_path / "s.csv"
    r = run_module("uamtoolkit_import.synth", "--fleet", "5", "--hours", "2", "--seed", "1", "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert out.read_text().startswith("flight_id,tail_id,aircraft_type,origin,destination,departure_time")
    assert "flights from" in r.stderr


# -------------------------------------------------------------------- windows
def test_find_window_is_exact_and_nearest_the_anchor():
    dep = np.arange(0, 10000, 10.0)  # one departure every 10 s
    start = find_window(dep, 600.0, 60, anchor_s=3000.0, day_s=10000.0)
    assert start == 3000.0
    assert ((dep >= start) & (dep < start + 600)).sum() == 60
    with pytest.raises(WindowNotFound):
        find_window(dep, 600.0, 100, anchor_s=0.0, day_s=10000.0)
