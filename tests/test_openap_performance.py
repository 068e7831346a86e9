"""Fixed-wing performance (BlueSky's OpenAP model, aamsim.traffic.openap) and its coefficient table.

Hand-computed cases for the phase rules and the ground and zero-airspeed
limits; BlueSky's own functions (``bluesky.traffic.performance.openap``) for
the thrust and drag model over random states; the committed coefficient table
against what BlueSky's loader reads from OpenAP. Whole trajectories are
checked against BlueSky in ``tests/conformance/scenarios/openap_fixwing.scn``.
"""

from __future__ import annotations

import json
import math
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.traffic import fields as f
from aamsim.traffic import openap
from aamsim.traffic.performance import PerformanceTable
from aamsim.units import FPM, FT, KTS

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize(("alt_ft", "roc_fpm", "phase"), [
    (0.0, 0.0, openap.PHASE_GD),
    (75.0, 0.0, openap.PHASE_GD),  # the ground rule includes 75 ft
    (75.0, 150.0, openap.PHASE_IC),  # ... but a climbing aircraft there is in its initial climb
    (500.0, 1500.0, openap.PHASE_IC),
    (500.0, -1500.0, openap.PHASE_AP),
    (500.0, 100.0, openap.PHASE_NA),  # low and nearly level: no rule applies
    (1000.0, 150.0, openap.PHASE_CL),  # at 1,000 ft climb wins over initial climb
    (1000.0, -150.0, openap.PHASE_DE),
    (5000.0, 0.0, openap.PHASE_NA),  # level below FL100 is not cruise
    (10000.0, 149.0, openap.PHASE_CR),
    (35000.0, -149.0, openap.PHASE_CR),
    (35000.0, 2000.0, openap.PHASE_CL),
])
def test_flight_phase_rules(alt_ft, roc_fpm, phase):
    assert openap.flight_phase(roc_fpm * FPM, alt_ft * FT) == phase


def _aircraft(actype: str, alt_ft: float, spd_kts: float) -> tuple[Simulation, int]:
    sim = Simulation(seed=0)
    sim.stack(f"CRE X {actype} 52 4 90 {alt_ft} {spd_kts}")
    return sim, sim.view.slot("X")


def test_standing_on_the_ground_gets_ground_limits_and_the_take_off_gate():
    sim, i = _aircraft("A320", 0, 0)
    F = sim._traffic.F
    assert openap.refresh(F, sim.view.n)
    a320 = PerformanceTable().lookup("A320")[0].openap
    assert a320 is not None
    assert F[f.PHASE, i] == openap.PHASE_GD
    assert F[f.VMIN, i] == 0.0 and F[f.VMAX, i] == a320.vmaxic_mps == 89.0
    assert F[f.AXMAX, i] == 2.0  # whatever the thrust: BlueSky's ground value
    assert F[f.TAKEOFF_TAS, i] == a320.vminto_mps == 74.5


def test_climbing_aircraft_have_no_take_off_gate_and_the_en_route_speed_range():
    sim, i = _aircraft("A320", 20000, 250)
    F = sim._traffic.F
    F[f.VS, i] = 2000 * FPM
    openap.refresh(F, sim.view.n)
    assert F[f.PHASE, i] == openap.PHASE_CL
    assert math.isnan(F[f.TAKEOFF_TAS, i])
    assert (F[f.VMIN, i], F[f.VMAX, i]) == (67.0, 163.0)  # OpenAP's A320 en-route CAS range
    assert 0.5 < F[f.AXMAX, i] < 2.0


def test_no_airspeed_in_flight_means_no_acceleration_limit():
    # Drag at zero airspeed is 0 x inf: BlueSky's limit becomes NaN and the speed takes its
    # command in one step; aamsim writes that as an infinite limit.
    sim, i = _aircraft("B744", 20000, 0)
    openap.refresh(sim._traffic.F, sim.view.n)
    assert sim._traffic.F[f.AXMAX, i] == math.inf


def test_slow_aircraft_keep_the_least_acceleration():
    # A B744 near its ceiling at its en-route minimum has more drag than thrust.
    sim, i = _aircraft("B744", 36000, 140)
    F = sim._traffic.F
    openap.refresh(F, sim.view.n)
    assert F[f.AXMAX, i] == openap.MIN_AXMAX


def test_rotorcraft_and_custom_fixed_wing_types_are_left_to_their_envelopes(tmp_path):
    table = json.loads(resources.files("aamsim.traffic").joinpath("data/performance.json").read_text())
    table["types"]["PLAIN"] = {"lift": "fixwing", "vmin_mps": 60.0, "vmax_mps": 150.0, "mmo": 0.8,
                               "vsmin_mps": -10.0, "vsmax_mps": 10.0, "hmax_m": 10000.0, "axmax_mps2": 1.5}
    table["types"]["B744"] = dict(table["types"]["PLAIN"])  # the default type must exist
    path = tmp_path / "perf.json"
    path.write_text(json.dumps(table))
    sim = Simulation(seed=0, performance=PerformanceTable(path))
    sim.stack("CRE P PLAIN 52 4 90 FL100 250")
    sim.stack("CRE H EC35 52 4 90 1500 100")
    assert not openap.refresh(sim._traffic.F, sim.view.n)
    sim.run_until(5)
    F = sim._traffic.F
    assert F[f.AXMAX, sim.view.slot("P")] == 1.5
    assert F[f.AXMAX, sim.view.slot("H")] == 3.5


def test_the_limits_follow_the_state_at_every_refresh():
    # Accelerating at FL100 from 250 to 300 kts, the thrust-limited acceleration falls as
    # the speed (so the drag) grows: 0.87 to 0.65 m/s^2 for an A320 (BlueSky flies the same
    # trajectory: tests/conformance/scenarios/openap_fixwing.scn), so 300 kts after about 38 s.
    sim, i = _aircraft("A320", 10000, 250)
    sim.stack("SPD X 300")
    seen = []
    for t in range(1, 40):
        sim.run_until(t)
        seen.append(sim._traffic.F[f.AXMAX, i])
    accelerating = [a for a in seen if a < 1.0]
    assert accelerating[0] > accelerating[-1]
    assert 0.85 < accelerating[0] < 0.90 and 0.63 < accelerating[-1] < 0.70
    assert sim._traffic.F[f.CAS, i] == pytest.approx(300 * KTS, abs=0.01)


def test_an_aircraft_on_the_ground_does_not_climb_below_its_take_off_speed():
    sim, i = _aircraft("B738", 0, 0)
    sim.stack("ALT X FL60")
    sim.stack("SPD X 180")
    vminto = PerformanceTable().lookup("B738")[0].openap.vminto_mps  # type: ignore[union-attr]
    F = sim._traffic.F
    while F[f.TAS, i] < vminto - 1.0:
        sim.run_until(sim.simt + 0.5)
        assert F[f.ALT, i] == 0.0 and F[f.VS, i] == 0.0
    sim.run_until(sim.simt + 10)
    assert F[f.ALT, i] > 0.0 and F[f.VS, i] > 0.0


# ------------------------------------------------------------------ against BlueSky's own model

bluesky_thrust = pytest.importorskip("bluesky.traffic.performance.openap.thrust")
bluesky_phase = pytest.importorskip("bluesky.traffic.performance.openap.phase")


@pytest.fixture(scope="module")
def bluesky_coefficients():
    from bluesky.traffic.performance.openap.coeff import Coefficient

    return Coefficient()


_ONE_AIRCRAFT: dict[str, Simulation] = {}  # one simulation per type, its state set by each example


@pytest.mark.bluesky
@settings(max_examples=300, deadline=None)
@given(actype=st.sampled_from(["A320", "B744", "E145", "A388", "GLF6"]), alt=st.floats(0.0, 13000.0),
       tas=st.floats(0.0, 300.0), vs=st.floats(-30.0, 30.0))
def test_refresh_agrees_with_bluesky(bluesky_coefficients, actype, alt, tas, vs):
    """One refresh of aamsim's model against BlueSky's phase, drag and thrust formulas."""
    from bluesky.tools import aero as bluesky_aero

    if actype not in _ONE_AIRCRAFT:
        _ONE_AIRCRAFT[actype] = Simulation(seed=0)
        _ONE_AIRCRAFT[actype].stack(f"CRE X {actype} 52 4 90 1000 250")
    F = _ONE_AIRCRAFT[actype]._traffic.F
    F[f.ALT, 0], F[f.TAS, 0], F[f.VS, 0] = alt, tas, vs
    assert openap.refresh(F, 1)

    a, v, w = np.array([alt]), np.array([tas]), np.array([vs])
    phase = int(bluesky_phase.get_fixwing(v, w, a, unit="SI")[0])
    assert F[f.PHASE, 0] == phase
    limits = bluesky_coefficients.limits_fixwing[actype]
    if phase == openap.PHASE_GD:
        assert (F[f.VMIN, 0], F[f.VMAX, 0], F[f.AXMAX, 0]) == (0.0, limits["vmaxic"], 2.0)
        assert F[f.TAKEOFF_TAS, 0] == limits["vminto"]
        return
    approach = phase == openap.PHASE_AP
    assert F[f.VMIN, 0] == (limits["vminap"] if approach else limits["vminer"])
    assert F[f.VMAX, 0] == (limits["vmaxap"] if approach else limits["vmaxer"])
    assert math.isnan(F[f.TAKEOFF_TAS, 0])
    polar, ac = bluesky_coefficients.dragpolar_fixwing[actype], bluesky_coefficients.acs_fixwing[actype]
    config = "ld" if approach else "to" if phase == openap.PHASE_IC else "clean"
    mass = 0.5 * (ac["oew"] + ac["mtow"])
    qs = 0.5 * float(bluesky_aero.vdensity(alt)) * tas**2 * ac["wing"]["area"]
    if qs == 0.0:
        assert F[f.AXMAX, 0] == math.inf
        return
    with np.errstate(over="ignore"):  # a crawl in flight: infinite drag, the least acceleration
        drag = qs * (polar[f"cd0_{config}"] + polar[f"k_{config}"] * np.float64(mass * bluesky_aero.g0 / qs) ** 2)
    engine = next(iter(ac["engines"].values()))
    thr0 = int(ac["engine"]["number"]) * engine["max_thrust"]
    thrust = float(bluesky_thrust.compute_max_thr_ratio(np.array([phase]), engine["bpr"], v, a, w, thr0)[0]) * thr0
    assert F[f.AXMAX, 0] == pytest.approx(max((thrust - drag) / mass, 0.5), rel=1e-9, abs=1e-12)


@pytest.mark.bluesky
def test_the_coefficient_table_is_what_bluesky_loads_from_openap():
    # scripts/openap_performance_table.py wrote it; writing it again must give the same table.
    import importlib.util

    spec = importlib.util.spec_from_file_location("openap_table", ROOT / "scripts" / "openap_performance_table.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    committed = json.loads(resources.files("aamsim.traffic").joinpath("data/openap_fixwing.json").read_text())
    assert module.build() == committed


def test_every_openap_type_and_synonym_is_known():
    table = PerformanceTable()
    committed = json.loads(resources.files("aamsim.traffic").joinpath("data/openap_fixwing.json").read_text())
    codes = set(committed["types"]) | {a for e in committed["types"].values() for a in e.get("aliases", [])}
    assert len(codes) == 58  # BlueSky 1.1.1 with OpenAP 2.6.2
    for code in codes:
        envelope, known = table.lookup(code)
        assert known and envelope.openap is not None and not envelope.rotor
    assert table.lookup("A124")[0].type_code == "B744"  # OpenAP's synonym
    assert table.lookup("ZZZ9") == (table.lookup("B744")[0], False)


def test_a_type_defined_twice_is_refused(tmp_path):
    table = json.loads(resources.files("aamsim.traffic").joinpath("data/performance.json").read_text())
    table["types"]["B744"] = {"lift": "fixwing", "aliases": ["EC135"], "vmin_mps": 60.0, "vmax_mps": 150.0,
                              "vsmin_mps": -10.0, "vsmax_mps": 10.0, "hmax_m": 10000.0, "axmax_mps2": 1.5}
    path = tmp_path / "perf.json"
    path.write_text(json.dumps(table))
    with pytest.raises(ValueError, match=r"perf.json: aircraft type EC135 is defined twice"):
        PerformanceTable(path)
