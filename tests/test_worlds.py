"""Several simulations over one traffic pool (aamsim.worlds): each world is exactly the simulation it is alone."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import count_calls

import aamsim.traffic.pool
import aamsim.worlds
from aamsim import Simulation
from aamsim.threads import THREADS_ENV, available_cores, check_threads
from aamsim.traffic.pool import TrafficPool
from aamsim.worlds import WorldSet


def _scenario(seed: int, n: int = 12) -> str:
    """Routes, a conditional command, deletions, creations later on, a speed change: events inside batches."""
    rng = np.random.default_rng(seed)
    lines = []
    for k in range(n):
        t = int(rng.integers(0, 40))
        lat, lon = 40.7 + rng.uniform(-0.05, 0.05), -74.0 + rng.uniform(-0.06, 0.06)
        stamp = f"00:00:{t:02d}.00>"
        lines.append(f"{stamp}CRE W{k} EC35 {lat:.5f} {lon:.5f} {rng.uniform(0, 360):.1f} "
                     f"{rng.uniform(800, 1600):.0f} {rng.uniform(40, 120):.0f}")
        if seed == 1 and k < 3:  # fly-turn waypoints in one world: the kernel's turn part runs for all of them
            lines.append(f"{stamp}ADDWPTMODE W{k} TURNSPD 25")
        for _ in range(int(rng.integers(1, 4))):
            lines.append(f"{stamp}ADDWPT W{k} {40.7 + rng.uniform(-0.05, 0.05):.5f} "
                         f"{-74.0 + rng.uniform(-0.06, 0.06):.5f}")
        if k % 3 == 0:
            lines.append(f"{stamp}W{k} ATDIST {lat:.5f} {lon + 0.01:.5f} 0.3 SPD W{k} 30")
    lines.append("00:00:25.00>ATALT W1 1000 ALT W2 900")
    lines.append("00:00:45.00>DEL W4")
    lines.append("00:01:10.00>SPD W3 20")
    return "\n".join(lines) + "\n"


def _fresh(sim: Simulation, text: str) -> Simulation:
    sim.services.start()
    sim.load_text(text)
    return sim


def _state(sim: Simulation):
    n = sim.view.n
    records = [(r.acid, r.deleted_s, r.arrived, r.distance_m) for r in sim.flight_log]
    conflicts = sim.services.conflicts
    events = [repr(e) for e in conflicts.events]  # every field, NaN included
    return (sim.simt_us, list(sim.view.ids), sim._traffic.F[:, :n].copy(), sim._traffic.B[:, :n].copy(), records,
            events)


def _same(a, b) -> None:
    assert a[0] == b[0] and a[1] == b[1]
    assert np.array_equal(a[2], b[2], equal_nan=True) and np.array_equal(a[3], b[3])
    assert a[4] == b[4] and a[5] == b[5]


def test_worlds_stepped_together_are_each_the_simulation_alone():
    texts = [_scenario(s) for s in range(4)]
    # Alone: each world runs to its own times.
    plans = [(20.0, 95.0), (57.35, 120.0), (3.0, 40.0), (80.0, 81.0)]
    alone = []
    for k, text in enumerate(texts):
        sim = _fresh(Simulation(seed=k, use_bluesky_navdata=False), text)
        for t in plans[k]:
            sim.run_until(t)
        alone.append(_state(sim))
    # Together: the same targets, every world in each call.
    worlds = WorldSet(4)
    for k, text in enumerate(texts):
        _fresh(worlds.new_simulation(k, seed=k, use_bluesky_navdata=False), text)
    for step in range(2):
        worlds.run_until({k: plans[k][step] for k in range(4)})
    for k in range(4):
        _same(_state(worlds.sim(k)), alone[k])
    assert worlds.kernel_calls > 0
    assert sum(len(a[5]) for a in alone) > 0 and sum(len(a[4]) for a in alone) > 0  # events and deletions happened


def test_a_world_reset_while_others_fly_on_and_the_pool_grows():
    """World 0 starts again twice (a vector environment's autoreset); world 1 creates more aircraft than a
    block holds, so every block grows in the middle of the run."""
    many = _scenario(7, n=80)
    small = _scenario(8)
    ref_many = _fresh(Simulation(seed=1, use_bluesky_navdata=False), many)
    ref_many.run_until(150.0)
    ref_small = _fresh(Simulation(seed=2, use_bluesky_navdata=False), small)
    ref_small.run_until(33.0)

    worlds = WorldSet(2)
    old = _fresh(worlds.new_simulation(0, seed=5, use_bluesky_navdata=False), small)
    _fresh(worlds.new_simulation(1, seed=1, use_bluesky_navdata=False), many)
    worlds.run_until({0: 40.0, 1: 50.0})
    kept = _state(old)
    _fresh(worlds.new_simulation(0, seed=2, use_bluesky_navdata=False), small)  # a new episode in world 0
    worlds.run_until({0: 33.0, 1: 150.0})
    assert worlds.pool.block > 64
    _same(_state(worlds.sim(0)), _state(ref_small))
    _same(_state(worlds.sim(1)), _state(ref_many))
    # The world's previous simulation kept its traffic (a copy) and was not stepped again.
    _same(_state(old), kept)


def test_worlds_in_a_wind_field_take_their_own_kernel_call():
    text = _scenario(3)
    wind = "00:00:00.00>WIND 40.7 -74.0 1000 270 20\n"
    ref = _fresh(Simulation(seed=3, use_bluesky_navdata=False), wind + text)
    ref.run_until(60.0)
    worlds = WorldSet(2)
    _fresh(worlds.new_simulation(0, seed=3, use_bluesky_navdata=False), wind + text)
    _fresh(worlds.new_simulation(1, seed=3, use_bluesky_navdata=False), text)
    worlds.run_until({0: 60.0, 1: 60.0})
    assert worlds.sim(0)._wind.active
    _same(_state(worlds.sim(0)), _state(ref))


def test_pool_and_world_set_refuse_bad_sizes():
    with pytest.raises(ValueError, match="at least one world"):
        WorldSet(0)
    with pytest.raises(ValueError, match="at least one world"):
        TrafficPool(0)
    with pytest.raises(IndexError):
        TrafficPool(2).new_traffic(2)


def test_thread_counts_above_the_cores_and_bad_environment_values_are_clear_errors(monkeypatch):
    cores = available_cores()
    with pytest.raises(ValueError, match=f"between 1 and {cores}, the CPU cores"):
        check_threads(cores + 1)
    with pytest.raises(ValueError, match="between 1"):
        WorldSet(2, threads=0)
    monkeypatch.setenv(THREADS_ENV, "lots")
    with pytest.raises(ValueError, match=f"{THREADS_ENV}='lots' is not a whole number"):
        Simulation(use_bluesky_navdata=False)
    monkeypatch.setenv(THREADS_ENV, str(cores + 1))
    with pytest.raises(ValueError, match=f"{THREADS_ENV} = {cores + 1}"):
        check_threads(None)
    monkeypatch.setenv(THREADS_ENV, str(cores))
    assert Simulation(use_bluesky_navdata=False).threads == cores
    assert Simulation(threads=1, use_bluesky_navdata=False).threads == 1  # the argument wins
    monkeypatch.delenv(THREADS_ENV)
    assert check_threads(None) == 1


@pytest.mark.slow
@pytest.mark.skipif(available_cores() < 2, reason="needs two CPU cores")
def test_worlds_on_two_threads_give_the_bits_of_one_thread(monkeypatch):
    """Above PARALLEL_MIN_AIRCRAFT in all, the worlds' ranges run on Numba's threads: the same bits."""
    # The threshold lowered to 1,000 (its value on this machine is several thousand): the same code path
    # on a quarter of the aircraft.
    monkeypatch.setattr(aamsim.worlds, "PARALLEL_MIN_AIRCRAFT", 1000)
    texts = [_scenario(s, n=aamsim.worlds.PARALLEL_MIN_AIRCRAFT // 2 + 100) for s in (11, 12)]
    calls = count_calls(monkeypatch, aamsim.traffic.pool, "advance_ranges_parallel")
    runs = []
    for threads in (1, 2):
        worlds = WorldSet(2, threads=threads)
        for k, text in enumerate(texts):
            _fresh(worlds.new_simulation(k, seed=k, use_bluesky_navdata=False), text)
        worlds.run_until({0: 45.0, 1: 50.0})
        runs.append([_state(worlds.sim(k)) for k in range(2)])
    assert sum(s.view.n for s in worlds.sims if s is not None) >= aamsim.worlds.PARALLEL_MIN_AIRCRAFT
    assert calls[0] > 0  # the two-thread run did use the parallel kernel
    for a, b in zip(*runs):
        _same(a, b)
