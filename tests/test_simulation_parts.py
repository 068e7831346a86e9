"""The simulation's parts (clock, scheduler, scenario files, command stack) and the handlers' narrow context."""

from __future__ import annotations

import inspect

import pytest

from aamsim import Simulation
from aamsim.clock import Clock, TimeStepError
from aamsim.hooks import Hooks
from aamsim.scheduler import Scheduler
from aamsim.stack.context import CommandContext
from aamsim.stack.parser import Command, TimedCommand


def test_clock_counts_exact_microseconds():
    clock = Clock(0.05)
    clock.advance(3)
    assert clock.simt_us == 150_000 and clock.simt == 0.15
    clock.set_dt(0.1)
    clock.advance(1)
    assert clock.simt_us == 250_000 and clock.dt_us == 100_000
    clock.reset()
    assert clock.simt_us == 0 and clock.dt_s == 0.1  # RESET keeps the step
    with pytest.raises(TimeStepError):
        clock.set_dt(0.0)
    assert clock.dt_s == 0.1  # a refused step changes nothing


def test_scheduler_counts_steps_to_the_next_event():
    clock, hooks = Clock(0.5), Hooks()
    scheduler = Scheduler(clock, hooks)
    assert scheduler.steps_to_next_event(10_000_000) == 20  # nothing due: up to the end, 10 s / 0.5 s
    scheduler.queue.push(TimedCommand(2.2, Command("ECHO", "x"), None))  # type: ignore[arg-type]
    assert scheduler.steps_to_next_event(10_000_000) == 5  # ceil(2.2 / 0.5): the batch ends at or after it
    calls = []
    hooks.post_step.add(lambda *a: calls.append(clock.simt), interval_s=1.5, name="every 1.5 s")
    scheduler.run_hooks("post_step")  # due at once, then every 1.5 s
    assert calls == [0.0] and scheduler.steps_to_next_event(10_000_000) == 3  # 1.5 s comes first
    hooks.pre_step.add(lambda *a: None, interval_s=0.0, name="every step")
    assert scheduler.steps_to_next_event(10_000_000) == 1


def test_scheduler_performance_timer_fires_once_per_interval_and_only_when_pending():
    clock = Clock(0.25)
    scheduler = Scheduler(clock, Hooks())
    step = clock.dt_us
    assert scheduler.performance_due(1.0, step) is False  # nothing pending
    scheduler.perf_pending = True
    clock.advance(1)  # 0.25 s: before the next refresh at 1 s
    assert scheduler.performance_due(1.0, step) is False and scheduler.perf_pending
    clock.advance(3)  # 1.0 s
    assert scheduler.performance_due(1.0, step) is True and not scheduler.perf_pending
    assert scheduler.next_perf_us == 2_000_000


def test_scheduler_performance_timer_after_a_batch_that_went_past_it():
    # Stepping one by one, the refresh runs at the first step boundary at or after 0, 1, 2, ... s.
    clock = Clock(0.25)
    scheduler = Scheduler(clock, Hooks())
    step = clock.dt_us
    assert scheduler.performance_due(1.0, step) is False  # 0 s, nothing pending
    clock.advance(14)  # one batch to 3.5 s: the boundaries at 1, 2 and 3 s refreshed nothing
    scheduler.perf_pending = True  # an aircraft created at 3.5 s
    assert scheduler.performance_due(1.0, step) is False and scheduler.perf_pending
    assert scheduler.next_perf_us == 4_000_000  # not at its creation: at the next time of the timer
    clock.advance(2)
    assert scheduler.performance_due(1.0, step) is True and not scheduler.perf_pending
    clock.advance(12)  # a batch to 7.0 s, a time of the timer, where an aircraft is created
    scheduler.perf_pending = True
    assert scheduler.performance_due(1.0, step) is True and scheduler.next_perf_us == 8_000_000
    # Times of the timer off the step grid: with 0.3 s steps the refresh of 9 s is due at 9.1 s.
    clock.set_dt(0.3)
    clock.advance(7)  # 9.1 s
    scheduler.perf_pending = True
    assert scheduler.performance_due(1.0, clock.dt_us) is True
    clock.advance(4)  # 10.3 s: the step boundary at 10.0 s was at the timer's time, with nothing pending
    scheduler.perf_pending = True
    assert scheduler.performance_due(1.0, clock.dt_us) is False and scheduler.next_perf_us == 11_000_000


def test_an_aircraft_created_after_a_long_batch_is_refreshed_where_stepping_one_by_one_refreshes_it():
    # T2 is created at 11.5 s; the last step boundary before it that a batch stopped at is 4 s (T1's first
    # refresh). Its acceleration limit is its type's from the refresh at 12 s on, however the steps ran.
    text = ("00:00:03.00>CRE T1 EC35 40.7 -74.01 0 1000 0\n00:00:03.00>ADDWPT T1 40.715 -73.985\n"
            "00:00:03.00>SPD T1 90\n00:00:11.50>CRE T2 EC35 40.735 -74.005 0 1000 0\n"
            "00:00:11.50>ADDWPT T2 40.725 -73.975\n00:00:11.50>SPD T2 70\n")
    batched, stepped = Simulation(seed=1), Simulation(seed=1)
    for sim in (batched, stepped):
        sim.load_text(text)
    batched.run_until(11.5)
    t2 = batched.slot("T2")
    axmax_at_creation = float(batched.view.axmax[t2])
    batched.run_until(40.0)
    while stepped.simt < 40.0 - 1e-9:
        stepped.step()
    assert stepped.simt == batched.simt == pytest.approx(40.0)
    assert batched.aircraft_steps > 0 and stepped.view.ids == batched.view.ids
    for name in ("lat", "lon", "hdg", "tas", "axmax"):
        assert getattr(batched.view, name).tolist() == getattr(stepped.view, name).tolist(), name
    assert axmax_at_creation != float(batched.view.axmax[t2])  # BlueSky's 2 m/s^2 until 12 s, then the type's


def test_scenario_files_and_dt_live_in_their_parts(tmp_path):
    (tmp_path / "a.scn").write_text("00:00:00>CRE A B744 52 4 0 FL100 250\n")
    sim = Simulation(seed=1, dt=0.1)
    sim.load_scenario(tmp_path / "a.scn")
    assert sim.files.name == "a" == sim.scenario_name and sim.files.path == tmp_path / "a.scn"
    assert sim.files.search_path[0] == tmp_path and "CRE A" in sim.files.text
    assert sim.find_file("a") == tmp_path / "a.scn"
    sim.stack("DT 0.2")
    assert sim._clock.dt_s == sim.dt == 0.2 and not hasattr(sim.settings, "dt_s")  # one owner of the step
    sim.run_until(1.0)
    assert sim.simt_us == sim._clock.simt_us == 1_000_000


def test_simulation_is_a_command_context_and_handlers_get_only_that():
    sim = Simulation()
    assert isinstance(sim, CommandContext)
    for spec in sim.commands.specs():
        first = next(iter(inspect.signature(spec.handler).parameters.values()))
        assert first.annotation in ("CommandContext", CommandContext), (spec.name, first.annotation)
    # What the protocol leaves out: the arrays, the kernel loop and the run control.
    members = set(dir(CommandContext))
    assert not {"traffic", "run", "run_until", "step", "executor", "scheduler", "clock"} & members


def test_a_handler_sees_the_context_it_was_given():
    simulation = Simulation()
    seen = []

    from aamsim.stack.registry import command

    @command("SEEN")
    def seen_cmd(sim: CommandContext) -> str:
        """SEEN: record the context."""
        seen.append(sim)
        return f"t={sim.simt:g}"

    simulation.commands.add(seen_cmd)
    assert simulation.stack("SEEN") and seen == [simulation]
    assert simulation.reporter.messages[-1].text == "t=0"


def _runtime_import_graph(package: str, *, type_checking: bool):
    grimp = pytest.importorskip("grimp", reason="grimp comes with import-linter (pip install 'aamsim[test]')")
    return grimp.build_graph(package, exclude_type_checking_imports=not type_checking)


# No import cycle inside aamsim, type-only imports included: tests/test_import_graph.py.


def test_the_stack_never_names_the_simulation_class():
    """Not even for type checking: handlers are written against CommandContext."""
    graph = _runtime_import_graph("aamsim", type_checking=True)
    importers = graph.find_modules_that_directly_import("aamsim.simulation")
    assert not {m for m in importers if m.startswith(("aamsim.stack", "aamsim.traffic"))}
