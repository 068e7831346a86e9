"""Simulation object: determinism, independence, batching, events."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from conftest import count_calls, errors_of

import aamsim.simulation
from aamsim import Simulation
from aamsim.scenarios import packaged_scenario
from aamsim.traffic import fields as f
from aamsim.units import FT


def run_demo(per_step_hook: bool = False, seed: int = 7) -> Simulation:
    sim = Simulation(seed=seed, use_bluesky_navdata=False)
    if per_step_hook:
        sim.hooks.post_step.add(lambda s: None, interval_s=0.0, name="every-step")
    sim.load_scenario(packaged_scenario("demo.scn"))
    sim.run_until(400.0)
    return sim


def state(sim):
    n = sim.view.n
    return sim.view.ids[:], sim._traffic.F[:, :n].copy(), sim._traffic.B[:, :n].copy()


def test_batched_stepping_is_bit_identical_to_single_steps():
    a, b = run_demo(False), run_demo(True)
    ids_a, F_a, B_a = state(a)
    ids_b, F_b, B_b = state(b)
    assert ids_a == ids_b
    assert np.array_equal(F_a, F_b, equal_nan=True)
    assert np.array_equal(B_a, B_b)


def test_same_seed_same_result_and_mcre_is_seeded():
    def go(seed):
        sim = Simulation(seed=seed, use_bluesky_navdata=False)
        sim.load_text("00:00:00.00>MCRE 20 EC35 1500 100\n")
        sim.run_until(30.0)
        return state(sim)
    a, b, c = go(3), go(3), go(4)
    assert a[0] == b[0] and np.array_equal(a[1], b[1], equal_nan=True)
    assert a[0] != c[0] or not np.array_equal(a[1], c[1], equal_nan=True)


def test_two_simulations_in_one_process_are_independent():
    s1 = Simulation(seed=1, use_bluesky_navdata=False)
    s2 = Simulation(seed=1, use_bluesky_navdata=False)
    s1.stack("CRE A EC35 0 0 90 1000 100")
    s1.stack("DEFWPT P1 1 1")
    s1.stack("ASAS ON")
    assert s2.view.n == 0 and not s2.navdb.known("P1") and s2.settings.cd_method == "OFF"
    s2.stack("CRE A EC35 10 10 0 1000 50")
    s1.run_until(10.0)
    assert s2.simt == 0.0 and s2.view.lat[0] == 10.0
    assert s1.view.lat[0] == pytest.approx(0.0)


def test_create_delete_keeps_callsign_map_consistent(sim):
    for k in range(50):
        sim.stack(f"CRE A{k} EC35 0 {k * 0.01} 90 1000 100")
    sim.stack("DEL A0 A10 A49 A25")
    assert sim.view.n == 46
    for k in range(50):
        acid = f"A{k}"
        if k in (0, 10, 25, 49):
            assert acid not in sim.view
        else:
            i = sim.view.slot(acid)
            assert sim.view.lon[i] == pytest.approx(k * 0.01)
    assert [r.acid for r in sim.flight_log] == ["A0", "A10", "A49", "A25"]


def test_duplicate_callsign_is_an_error_and_run_goes_on(sim):
    sim.load_text("00:00:00.00>CRE A EC35 0 0 90 1000 100\n00:00:01.00>CRE A EC35 1 1 0 1000 100\n"
                  "00:00:02.00>ECHO still running\n")
    sim.run_until(3.0)
    errs = errors_of(sim)
    assert len(errs) == 1 and "A already exists" in errs[0] and errs[0].startswith("<scenario>:2:")
    assert sim.view.lat[0] != 1.0
    assert any(m.text == "still running" for m in sim.reporter.messages)


def test_quiescent_when_everything_is_done(sim):
    sim.load_text("00:00:00.00>CRE A EC35 0 0 90 1000 100\n00:00:00.00>ADDWPT A 0 0.01\n")
    sim.run()
    # The aircraft passed its only waypoint and flies on without a route: nothing left to happen.
    assert sim.view.n == 1 and sim.simt <= 60.0  # checked every 60 s of sim time


def test_run_ends_when_only_unfireable_conditions_wait(sim):
    # The aircraft flies away from the ATDIST point: the condition can never fire.
    sim.load_text("00:00:00.00>CRE A EC35 0 0 90 1000 100\n00:00:00.00>A ATDIST 1 1 0.05 DEL A\n")
    sim.run()
    assert sim.view.n == 1 and 3600.0 <= sim.simt <= 3700.0
    assert any("never fired" in m.text for m in sim.reporter.messages)


def _route_traffic(n: int, seed: int = 3) -> str:
    rng = np.random.default_rng(seed)
    lines = []
    for k in range(n):
        lat, lon = 40.7 + rng.uniform(-0.25, 0.25), -74.0 + rng.uniform(-0.3, 0.3)
        lines.append(f"00:00:00.00>CRE P{k} EC35 {lat:.5f} {lon:.5f} {rng.uniform(0, 360):.1f} 1500 "
                     f"{rng.uniform(60, 140):.0f}")
        for _ in range(3):
            lines.append(f"00:00:00.00>ADDWPT P{k} {40.7 + rng.uniform(-0.25, 0.25):.5f} "
                         f"{-74.0 + rng.uniform(-0.3, 0.3):.5f}")
    lines.append("00:00:05.00>ATALT P1 1400 ALT P2 900")  # a conditional command inside the batches
    lines.append("00:00:10.00>ALT P1 1000")
    lines.append("00:00:20.00>DEL P5")
    return "\n".join(lines) + "\n"


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two CPUs")
def test_two_threads_below_the_parallel_threshold_step_serially(monkeypatch):
    """Below PARALLEL_MIN_AIRCRAFT the threads would cost more than they save (they meet every step):
    a two-thread simulation runs the serial kernel there, and the parallel one from the threshold on."""
    calls = count_calls(monkeypatch, aamsim.simulation, "advance_parallel")
    # 1,000 aircraft, where two threads ran the kernel at half the serial speed (speed.md, "Threads").
    sim = Simulation(seed=1, use_bluesky_navdata=False, threads=2)
    sim.load_text(_route_traffic(1000))
    sim.run_until(2.0)
    assert sim.view.n == 1000 and calls[0] == 0
    monkeypatch.setattr(aamsim.simulation, "PARALLEL_MIN_AIRCRAFT", 30)
    sim = Simulation(seed=1, use_bluesky_navdata=False, threads=2)
    sim.load_text(_route_traffic(29))
    sim.run_until(10.0)
    assert sim.view.n == 29 and calls[0] == 0
    sim.stack("CRE EXTRA EC35 40.7 -74.0 90 1500 100")
    sim.run_until(12.0)
    assert sim.view.n == 30 and calls[0] > 0


def test_thread_count_is_validated():
    with pytest.raises(ValueError):
        Simulation(threads=0, use_bluesky_navdata=False)
    with pytest.raises(ValueError):
        Simulation(threads=numba.config.NUMBA_NUM_THREADS + 1, use_bluesky_navdata=False)


@pytest.mark.slow
@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two CPUs")
def test_parallel_kernel_gives_the_same_bits_as_the_serial_one(monkeypatch):
    # The threshold lowered to 1,000 (its value on this machine is several thousand): the same code path
    # on a quarter of the aircraft.
    monkeypatch.setattr(aamsim.simulation, "PARALLEL_MIN_AIRCRAFT", 1000)
    n = aamsim.simulation.PARALLEL_MIN_AIRCRAFT
    text = _route_traffic(n + 44)
    calls = count_calls(monkeypatch, aamsim.simulation, "advance_parallel")
    runs = []
    for threads in (1, 2):
        sim = Simulation(seed=1, use_bluesky_navdata=False, threads=threads)
        sim.load_text(text)
        sim.run_until(120.0)
        runs.append(state(sim))
    (ids_a, F_a, B_a), (ids_b, F_b, B_b) = runs
    assert ids_a == ids_b and len(ids_a) == n + 43
    assert calls[0] > 0  # the two-thread run did use the parallel kernel
    assert F_a[f.SELALT, ids_a.index("P2")] == pytest.approx(900 * FT)  # the condition fired
    assert np.array_equal(F_a, F_b, equal_nan=True) and np.array_equal(B_a, B_b)
