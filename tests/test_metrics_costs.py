"""The operational cost metrics count what a policy costs: parked aircraft hold, unfinished flights are late.

Issue 28: an aircraft held at 0 kt from its creation had ``airborne_holding_s = 0``, and delay and
flight time counted arrived flights only, so a policy that parks aircraft looked free and fast.
"""

from __future__ import annotations

import math

import pytest

from aamsim import Simulation
from aamsim.metrics.registry import MetricContext
from aamsim.traffic.traffic import FlightRecord

DT = 0.05


def _holding_s(sim: Simulation) -> dict[str, float]:
    return {f.acid: f.slow_s for f in sim.flights()}


def test_an_aircraft_held_from_its_creation_holds_for_its_whole_airborne_time():
    sim = Simulation(seed=1, dt=DT)
    sim.stack("CRE PARK EC35 40.70 -74.00 0 1000 0; SPD PARK 0")
    sim.run_until(120.0)
    flight = next(iter(sim.flights()))
    assert flight.airborne_s == pytest.approx(120.0)
    assert flight.slow_s == pytest.approx(120.0)  # was 0.0: it never "had moved"
    assert sim.services.start().metrics.compute(sim, ("operational",))["operational"]["airborne_holding_s"] == pytest.approx(120)


def test_the_spin_up_after_a_creation_at_zero_speed_is_not_holding():
    sim = Simulation(seed=1, dt=DT)
    sim.stack("CRE GO EC35 40.70 -74.00 0 1000 0; SPD GO 100")
    sim.run_until(60.0)
    assert _holding_s(sim) == {"GO": 0.0}


def test_an_aircraft_that_flies_then_stops_holds_from_when_it_is_slow():
    sim = Simulation(seed=1, dt=DT)
    sim.stack("CRE STOP EC35 40.70 -74.00 0 1000 60")
    sim.run_until(30.0)
    sim.stack("SPD STOP 0")
    threshold_mps = sim.settings.hold_speed_mps
    while sim.view.tas[0] >= threshold_mps:
        sim.run_until(sim.simt + DT)
    slow_from = sim.simt  # the first step that ended under 5 kt
    assert 30.0 < slow_from < 60.0
    sim.run_until(90.0)
    assert _holding_s(sim)["STOP"] == pytest.approx(90.0 - slow_from + DT, abs=1e-6)


def _flight(acid: str, created: float, deleted: float, arrived: bool, rta: float = math.nan) -> FlightRecord:
    return FlightRecord(acid, "EC35", created, deleted_s=deleted, arrived=arrived, scheduled_arrival_s=rta)


def test_delay_and_flight_time_count_unfinished_flights_to_the_end_of_their_record():
    sim = Simulation(seed=1)
    flights = [
        _flight("ARR", created=0.0, deleted=600.0, arrived=True, rta=500.0),  # 100 s late
        _flight("FLY", created=100.0, deleted=math.nan, arrived=False, rta=700.0),  # still flying at 1,000 s
        _flight("DEL", created=200.0, deleted=400.0, arrived=False, rta=900.0),  # deleted early, not arrived
        _flight("NOR", created=0.0, deleted=300.0, arrived=True),  # no scheduled arrival: no delay
    ]
    ctx = MetricContext(sim=sim, flights=flights, events=[], duration_s=1000.0, hold_speed_mps=2.57)
    op = sim.services.start().metrics.registry.compute(("operational",), ctx)["operational"]
    # Flight times 600, 900 (to the end of the run), 200 (to its deletion), 300.
    assert op["mean_flight_time_s"] == pytest.approx((600 + 900 + 200 + 300) / 4)
    # Delays 100, 1,000 - 700 = 300, 400 - 900 = -500 (a lower bound: it never arrived).
    assert op["mean_delay_s"] == pytest.approx((100 + 300 - 500) / 3)
    assert op["mean_flight_time_completed_s"] == pytest.approx((600 + 300) / 2)
    assert op["mean_delay_completed_s"] == pytest.approx(100.0)
    assert op["flights_unfinished"] == 2 and op["flights_completed"] == 2


def test_a_policy_that_parks_aircraft_no_longer_looks_faster():
    """Same two flights; in the second run one of them is parked: its delay and flight time grow."""
    def run(park: bool) -> dict:
        sim = Simulation(seed=1, dt=0.1)
        sim.stack("DEFWPT VA 40.72 -74.00; DEFWPT VB 40.82 -74.00")
        # 2.2 km at 100 kt: about 45 s of flight, 60 s scheduled, deleted within 0.05 NM as uam2scn does.
        sim.stack("CRE A EC35 40.70 -74.00 0 1000 100; DEST A VA; VNAV A OFF; RTA A VA 00:01:00; A ATDIST VA 0.05 DEL A")
        sim.stack("CRE B EC35 40.80 -74.00 0 1000 100; DEST B VB; VNAV B OFF; RTA B VB 00:01:00; B ATDIST VB 0.05 DEL B")
        if park:
            sim.stack("SPD A 0")
        sim.run_until(900.0)
        return sim.services.start().metrics.compute(sim, ("operational",))["operational"]

    flown, parked = run(False), run(True)
    assert flown["flights_unfinished"] == 0 and parked["flights_unfinished"] == 1
    assert parked["mean_delay_completed_s"] == pytest.approx(flown["mean_delay_completed_s"], abs=1.0)
    # A's delay is now 900 - 60 s (the run's end) instead of a few seconds early.
    assert parked["mean_delay_s"] == pytest.approx((flown["mean_delay_s"] * 2 + 840.0 - flown["mean_delay_s"]) / 2,
                                                   abs=1.0)
    assert parked["mean_flight_time_s"] > flown["mean_flight_time_s"]
    assert parked["airborne_holding_s"] > 800.0 and flown["airborne_holding_s"] == 0.0
