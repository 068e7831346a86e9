"""Sleeping hooks (aamsim/hooks.py) and the services whose idle cycles sleep.

The MVP and DAA cycles while RESO names another method, the DAA route keeper while
nobody is steered and the conflict check while paused sleep instead of ending a batch
of kernel steps at each of their times (MVP's one step before every second). Whatever
wakes them, and whenever, the run must be the one it was with every hook awake, bit
for bit.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import count_calls

import aamsim.simulation as simulation_module
from aamsim import Simulation
from aamsim.clock import Clock
from aamsim.hooks import HookList, sleep_while_unchanged

# A head-on pair (tests/test_mvp_resolution.py) that meets at about 68 s unless MVP or DAA resolves it:
# the cycle that first acts after RESO MVP or DAA decides the whole encounter.
HEAD_ON = (
    "00:00:00.00>ASAS ON\n00:00:00.00>ZONER 0.3\n00:00:00.00>ZONEDH 300\n00:00:00.00>DTLOOK 60\n"
    "00:00:00.00>CRE A EC35 40.70 -74.00 90 1500 120\n00:00:00.00>ADDWPT A 40.70 -73.85\n"
    "00:00:00.00>CRE B EC35 40.70 -73.90 270 1500 120\n00:00:00.00>ADDWPT B 40.70 -74.05\n"
)


# ------------------------------------------------------------------------------- HookList.sleep
def test_a_sleeping_hook_is_neither_run_nor_waited_for_and_wakes_where_it_says():
    hooks = HookList(periodic=True)
    ran: list[tuple[str, int]] = []
    a = hooks.add(lambda now: ran.append(("a", now)), name="a", interval_s=1.0)
    hooks.add(lambda now: ran.append(("b", now)), name="b", interval_s=3.0)
    hooks.call_due(0, 50_000, 0)
    assert ran == [("a", 0), ("b", 0)] and hooks.next_due_us() == 1_000_000
    asked: list[tuple[int, bool]] = []
    awake = {"now": False}

    def wake(now_us: int, ran_now: bool, *args: object) -> bool:
        asked.append((now_us, ran_now))
        if awake["now"]:
            a.next_due_us = 4_000_000
        return awake["now"]

    hooks.sleep(a, wake)
    assert hooks.sleeping == 1 and hooks.next_due_us() == 3_000_000  # only b is waited for
    hooks.call_due(3_000_000, 50_000, 3)
    assert ran[-1] == ("b", 3) and asked == [(3_000_000, False)]
    hooks.wake_sleepers(3_000_000)  # after the boundary's commands: the list ran at this time
    assert asked[-1] == (3_000_000, True)
    awake["now"] = True
    hooks.call_due(3_500_000, 50_000, 3.5)
    assert hooks.sleeping == 0 and a.wake is None and hooks.next_due_us() == 4_000_000
    assert ran[-1] == ("b", 3)  # a woke with its next due time in the future: not run now
    hooks.call_due(4_000_000, 50_000, 4)
    assert ran[-1] == ("a", 4)


def test_restart_and_remove_forget_sleepers():
    hooks = HookList(periodic=True)
    a = hooks.add(lambda: None, name="a", interval_s=1.0)
    b = hooks.add(lambda: None, name="b", interval_s=1.0)
    hooks.sleep(a, lambda *args: False)
    hooks.sleep(b, lambda *args: False)
    hooks.sleep(b, lambda *args: False)  # asleep already: counted once
    assert hooks.sleeping == 2 and hooks.next_due_us() is None
    hooks.remove("a")
    assert hooks.sleeping == 1
    hooks.restart(0)
    assert hooks.sleeping == 0 and b.wake is None and hooks.next_due_us() == 0


def _clock_at(simt_us: int) -> Clock:
    clock = Clock(0.05)
    clock.simt_us = simt_us
    return clock


def test_sleep_while_unchanged_wakes_due_where_the_runs_slept_through_would_have_left_it():
    hooks = HookList(periodic=True)
    hook = hooks.add(lambda: None, name="h", interval_s=1.0, start_us=5_000_000)
    state = {"x": 0}
    slept: list[int | None] = []
    # Running at its due time 5 s (dt 50 ms): from now on it is due at 6, 7, 8, ... s.
    assert sleep_while_unchanged(hooks, hook, _clock_at(5_000_000), lambda: state["x"], slept.append)
    hook.next_due_us = 6_000_000  # what call_due sets after the run
    hooks.wake_sleepers(8_300_000)
    assert hook.wake is not None and slept == []  # nothing changed: asleep
    state["x"] = 1
    hooks.wake_sleepers(8_300_000)  # ran at 6, 7 and 8 s
    assert hook.wake is None and hook.next_due_us == 9_000_000 and slept == [8_000_000]
    # At a due time: with the list run there it counts (ran_now), before the list runs it does not.
    for ran_now, due, last in ((True, 10_000_000, 9_000_000), (False, 9_000_000, 8_000_000)):
        hook.next_due_us = 6_000_000
        state["x"] = 0
        sleep_while_unchanged(hooks, hook, _clock_at(5_000_000), lambda: state["x"], slept.append)
        state["x"] = 1
        hooks._last_call_us = 9_000_000 if ran_now else 8_950_000
        hooks.wake_sleepers(9_000_000)
        assert (hook.next_due_us, slept[-1]) == (due, last)
    # Woken before its next due time: nothing slept through.
    sleep_while_unchanged(hooks, hook, _clock_at(9_000_000), lambda: state["x"], slept.append)
    hook.next_due_us = 10_000_000
    state["x"] = 2
    hooks.wake_sleepers(9_400_000)
    assert hook.next_due_us == 10_000_000 and slept[-1] is None
    # Due times that would not all be step boundaries: it stays awake.
    odd = hooks.add(lambda: None, name="odd", interval_s=0.33, start_us=9_000_000)
    assert not sleep_while_unchanged(hooks, odd, _clock_at(9_000_000), lambda: 0)
    assert not sleep_while_unchanged(hooks, hook, _clock_at(9_020_000), lambda: 0)
    assert hook.wake is None and odd.wake is None


# ------------------------------------------------------------------------- the services' idle cycles
def _run(text: str, sleep: bool, monkeypatch: pytest.MonkeyPatch, between=None, until: float = 90.0,
         stepping: bool = False):
    """The head-on run with ``text`` added; ``between(sim)`` is called once the run reached 6 s.

    Returns the final state and how many times a hook went to sleep.
    """
    with monkeypatch.context() as m:
        _keep_awake(m, sleep)
        sleeps = count_calls(m, HookList, "sleep")
        sim = Simulation(seed=0, use_bluesky_navdata=False)
        sim.services.start()
        sim.load_text(HEAD_ON + text)
        for end, action in ((6.0, between), (until, None)):
            if stepping:  # BlueSky's way: one step per call (aamsim.compat.bluesky)
                while sim.simt < end - 1e-9:
                    sim.step()
            else:
                sim.run_until(end)
            if action is not None:
                action(sim)
        return _final_state(sim), sleeps[0]


def _keep_awake(m: pytest.MonkeyPatch, sleep: bool) -> None:
    if not sleep:  # the reference: every hook stays awake
        m.setattr(HookList, "sleep", lambda self, hook, wake: None)


def _final_state(sim: Simulation) -> tuple:
    n = sim.view.n
    mvp, daa = sim.services.mvp, sim.services.daa
    return (sim.simt_us, list(sim.view.ids), sim._traffic.F[:, :n].copy(), sim._traffic.B[:, :n].copy(),
            mvp.resolutions, sorted(mvp.pairs), sorted(mvp.following),
            [repr(e) for e in sim.services.conflicts.events], daa.issued, sorted(daa.keeper.steered.items()),
            {h.name: h.next_due_us for h in sim.hooks.post_step if h.wake is None})  # asleep: no due time


def _assert_same(awake: tuple, asleep: tuple) -> None:
    a, b = awake, asleep
    assert a[0] == b[0] and a[1] == b[1]
    assert np.array_equal(a[2], b[2], equal_nan=True) and np.array_equal(a[3], b[3])
    assert a[4:10] == b[4:10]
    # The hooks awake at the end are due when they would have been.
    assert b[10] and {name: a[10][name] for name in b[10]} == b[10]


def _set_reso(method: str):
    def between(sim: Simulation) -> None:
        sim.settings.reso = method
    return between


def _stack(line: str):
    def between(sim: Simulation) -> None:
        sim.stack(line)
    return between


CASES = {
    # RESO MVP by a scenario line: one step before a second (a cycle's time), on the second, between.
    "line on a cycle": ("00:00:05.95>RESO MVP\n", None, False),
    "line on the second": ("00:00:06.00>RESO MVP\n", None, False),
    "line between": ("00:00:06.30>RESO MVP\n", None, False),
    "line at the first cycle": ("00:00:00.95>RESO MVP\n", None, False),
    # DT ASAS or DT changed while it sleeps: its phase moves as it would have awake.
    "DT ASAS 2 asleep": ("00:00:02.00>DT ASAS 2\n00:00:09.00>RESO MVP\n", None, False),
    "DT ASAS 0.7 asleep": ("00:00:02.30>DT ASAS 0.7\n00:00:09.00>RESO MVP\n", None, False),
    "DT ASAS 0.33 (not whole steps)": ("00:00:02.30>DT ASAS 0.33\n00:00:09.00>RESO MVP\n", None, False),
    "DT 0.1 asleep": ("00:00:03.00>DT 0.1\n00:00:10.00>RESO MVP\n", None, False),
    # On, off (everybody released), on again.
    "on, off, on": ("00:00:00.00>RESO MVP\n00:00:21.00>RESO OFF\n00:00:24.50>RESO MVP\n", None, False),
    "another method": ("00:00:04.00>RESO DAA\n00:00:08.00>RESO MVP\n", None, False),
    # Through the API between two calls of run_until, and while stepped one step at a time.
    "API settings": ("", _set_reso("MVP"), False),
    "API stack": ("", _stack("RESO MVP"), False),
    "API settings, stepped": ("", _set_reso("MVP"), True),
    "API stack, stepped": ("", _stack("RESO MVP"), True),
    # DAA (its cycle and its route keeper sleep too): by a line on the second, between, through the API.
    "DAA line on the second": ("00:00:06.00>RESO DAA\n", None, False),
    "DAA line between": ("00:00:06.30>RESO DAA\n", None, False),
    "DAA API stepped": ("", _stack("RESO DAA"), True),
    "DAA on, off, on": ("00:00:00.00>RESO DAA\n00:00:22.00>RESO OFF\n00:00:25.50>RESO DAA\n", None, False),
}


@pytest.mark.parametrize("case", list(CASES))
def test_an_idle_mvp_cycle_that_sleeps_gives_the_same_run(case, monkeypatch):
    text, between, stepping = CASES[case]
    awake, _ = _run(text, False, monkeypatch, between, stepping=stepping)
    asleep, slept = _run(text, True, monkeypatch, between, stepping=stepping)
    _assert_same(awake, asleep)
    assert slept >= 1  # it did sleep
    assert asleep[4] >= 1 or asleep[8] >= 1  # and MVP or DAA resolved the pair in the end


def _awake_and_asleep(monkeypatch: pytest.MonkeyPatch, run) -> tuple[tuple, tuple]:
    """``run(sim, sleep)`` on a fresh simulation with its services, hooks awake, then sleeping."""
    states = []
    for sleep in (False, True):
        with monkeypatch.context() as m:
            _keep_awake(m, sleep)
            sim = Simulation(seed=0, use_bluesky_navdata=False)
            sim.services.start()
            run(sim, sleep)
            states.append(_final_state(sim))
    return states[0], states[1]


def test_a_hook_ahead_of_the_cycle_that_switches_mvp_on_at_its_time(monkeypatch):
    # A plugin's post-step hook, run before MVP's (priority 15), switches it on at 5.95 s: one step
    # before a second, when the MVP cycle runs in the same call, after it.
    def run(sim: Simulation, sleep: bool) -> None:
        sim.hooks.post_step.add(lambda s: setattr(s.settings, "reso", "MVP") if s.simt_us == 5_950_000 else None,
                                name="plugin", priority=12, interval_s=0.05)
        sim.load_text(HEAD_ON)
        sim.run_until(5.0)
        assert (sim.services.mvp._hook.wake is not None) == sleep
        sim.run_until(90.0)

    _assert_same(*_awake_and_asleep(monkeypatch, run))


def test_reset_wakes_the_cycle(monkeypatch):
    def run(sim: Simulation, sleep: bool) -> None:
        sim.load_text(HEAD_ON)
        sim.run_until(10.0)
        assert (sim.services.mvp._hook.wake is not None) == sleep
        sim.stack("RESET")
        assert sim.hooks.post_step.sleeping == 0
        sim.load_text("00:00:03.95>RESO MVP\n" + HEAD_ON)
        sim.run_until(90.0)

    awake, asleep = _awake_and_asleep(monkeypatch, run)
    _assert_same(awake, asleep)
    assert asleep[4] == 1


def test_idle_resolutions_no_longer_end_batches_and_a_paused_check_neither(monkeypatch):
    # Two aircraft on straight legs, ASAS on: the conflict check (each second) and the idle MVP
    # cycle (one step before each second) ended the kernel's batches: two calls a second.
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.services.start()
    sim.load_text("00:00:00.00>ASAS ON\n00:00:00.00>CRE A EC35 40.70 -74.00 90 1500 120\n"
                  "00:00:00.00>CRE B EC35 40.75 -73.90 270 1500 120\n")
    sim.run_until(2.0)
    calls = count_calls(monkeypatch, simulation_module, "advance")
    sim.run_until(62.0)
    asleep = {h.name for h in sim.hooks.post_step if h.wake is not None}
    assert asleep == {"mvp", "daa", "daa.route_keeper"}
    assert calls[0] == 60  # one call per second, from one conflict check to the next
    # Paused (a single-agent episode before its ego), the check sleeps too: one call in all.
    sim.services.conflicts.paused = True
    sim.run_until(63.0)
    calls[0] = 0
    sim.run_until(123.0)
    assert calls[0] == 1 and sim.hooks.post_step.sleeping == 4


def _paused_run(sleep: bool, unpause, monkeypatch: pytest.MonkeyPatch):
    with monkeypatch.context() as m:
        _keep_awake(m, sleep)
        sim = Simulation(seed=0, use_bluesky_navdata=False)
        sim.services.start()
        sim.load_text(HEAD_ON + "00:00:30.35>CRE C EC35 40.69 -73.93 0 1500 100\n")
        sim.run_until(4.0)
        service = sim.services.conflicts
        service.paused = True
        unpause(sim)
        sim.run_until(120.0)  # A and B meet at about 68 s
        assert not service.paused
        return [repr(e) for e in service.events], service._last_check_s, service._hook.next_due_us


def _unpause_at(t: float):
    def unpause(sim: Simulation) -> None:
        sim.run_until(t)
        sim.services.conflicts.paused = False
    return unpause


def _unpause_on_creation(sim: Simulation) -> None:
    # As a single-agent episode does: its ego's creation (a CRE line, at a boundary) ends the pause.
    def created(s: Simulation, slot: int) -> None:
        s.services.conflicts.paused = False
    sim.hooks.created.add(created, name="ego")


def _unpause_then_delete(sim: Simulation) -> None:
    # The pause ends and, before the next boundary, X is deleted: the deletion's check looks back to the
    # last check slept through, not to the one before the pause. X and Y fly inside LoWC all along.
    sim.stack("CRE X EC35 40.60 -74.00 90 1500 100; CRE Y EC35 40.6025 -74.00 90 1500 100")
    sim.run_until(30.35)
    sim.services.conflicts.paused = False
    sim.stack("DEL X")


@pytest.mark.parametrize("unpause", [_unpause_at(20.0), _unpause_at(20.3), _unpause_at(67.0), _unpause_on_creation,
                                     _unpause_then_delete],
                         ids=["API on the second", "API between", "API during the encounter", "on a creation",
                              "API, then a deletion"])
def test_a_paused_check_that_sleeps_looks_back_as_it_would_have(unpause, monkeypatch):
    awake = _paused_run(False, unpause, monkeypatch)
    asleep = _paused_run(True, unpause, monkeypatch)
    assert awake == asleep
    assert awake[0]  # the encounter's separation events were recorded after the pause
