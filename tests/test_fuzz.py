"""A short run of the scenario fuzzing harness (the long one: ``python -m tests.fuzz --lines 1000000``).

No line may end the run with an exception; the time budget is generous here
because CI machines are shared (the long run reports lines over 1 s).
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.stack.parser import parse_scenario
from tests.fuzz.files import fuzz_batch, fuzz_uam2scn
from tests.fuzz.scenario import TYPE_VALUES, WORDS, Harness, LineMaker
from tests.fuzz.viewer_ws import fuzz_viewer

SPECS = list(Simulation(use_bluesky_navdata=False).commands.specs())
# One harness for all hypothesis examples: a fresh simulation every 50 lines (creating one per
# example would dominate the test's time).
SHARED = Harness(Path("."), budget_s=30.0, hard_limit_s=60.0, fresh_every=50)


def test_two_thousand_random_lines_neither_crash_nor_hang(tmp_path: Path) -> None:
    logging.disable(logging.CRITICAL)
    try:
        harness = Harness(tmp_path, budget_s=30.0, hard_limit_s=60.0)
        for line in LineMaker(seed=0).lines(2000):
            harness.run(line)
    finally:
        logging.disable(logging.NOTSET)
    assert harness.lines_run == 2000
    assert [(f.kind, f.detail, f.line) for f in harness.failures] == []


@st.composite
def command_lines(draw: st.DrawFn) -> str:
    """A command of the table with arguments drawn per argument type: good, edge, absurd or any text."""
    spec = draw(st.sampled_from(SPECS))
    args = []
    for param in spec.params:
        values = TYPE_VALUES.get(param.argtype.name, WORDS)
        args.append(draw(st.one_of(st.sampled_from(values), st.text(max_size=12))))
    stamp = draw(st.sampled_from(["00:00:00.00>", "00:00:01.00>", "", "00:00:1e308>"]))
    return stamp + spec.name + " " + draw(st.sampled_from([" ", ",", ", "])).join(args)


@settings(max_examples=300, deadline=None)
@given(command_lines())
def test_every_command_with_any_arguments_is_run_or_reported(line: str) -> None:
    SHARED.failures.clear()
    logging.disable(logging.CRITICAL)
    try:
        SHARED.run_in_memory(line)
    finally:
        logging.disable(logging.NOTSET)
    assert [(f.kind, f.detail) for f in SHARED.failures] == []


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=300))
def test_arbitrary_text_parses_into_commands_and_errors_never_an_exception(text: str) -> None:
    parsed = parse_scenario(text, "any.scn", is_command=lambda name: name in ("ECHO", "CRE", "SPD"))
    assert all(err.source.path == "any.scn" and err.source.line >= 1 for err in parsed.errors)


def test_a_slow_line_fails_the_harness_only_when_it_is_slow_again_alone(tmp_path: Path) -> None:
    """Issue 26: a line slow among the others (a loaded machine, Numba compiling on the first line) is
    rerun alone in a fresh simulation; only a line slow there too is a failure."""
    harness = Harness(tmp_path, budget_s=30.0, hard_limit_s=60.0)
    harness._slow("00:00:00.00>ECHO quick", "took 45.00 s", 45.0)  # what a loaded machine reported
    assert harness.failures == [] and [f.line for f in harness.unconfirmed_slow] == ["00:00:00.00>ECHO quick"]
    strict = Harness(tmp_path, budget_s=0.0, hard_limit_s=60.0)  # every line is over a budget of 0 s
    strict._slow("00:00:00.00>ECHO quick", "took 45.00 s", 45.0)
    assert [(f.kind, f.line) for f in strict.failures] == [("slow", "00:00:00.00>ECHO quick")]
    assert "again alone" in strict.failures[0].detail


class _HangingHarness(Harness):
    """A harness whose simulations know one more command, HANG, that never returns (a real hang)."""

    def _fresh(self) -> Simulation:
        sim = super()._fresh()

        def hang(sim: object) -> None:
            while True:
                time.sleep(0.01)

        sim.commands.add(hang, name="HANG")
        return sim


def test_a_line_that_hangs_fails_the_harness_also_when_rerun_alone(tmp_path: Path) -> None:
    """The rerun alone does not excuse a real hang: it is stopped by its own limit and reported."""
    harness = _HangingHarness(tmp_path, budget_s=0.5, hard_limit_s=1.0, rerun_limit_s=2.0)
    harness.run("00:00:00.00>ECHO before")
    harness.run("00:00:00.00>HANG")
    harness.run("00:00:00.00>ECHO after")
    assert harness.lines_run == 3
    assert [(f.kind, f.line) for f in harness.failures] == [("slow", "00:00:00.00>HANG")]
    assert "still running after 1 s; again alone: still running after 2." in harness.failures[0].detail


def test_the_kernels_are_warm_before_the_first_line_is_timed(tmp_path: Path) -> None:
    """Numba compiling on a cold cache (over a minute on a loaded 2-core machine) is paid by the warm-up,
    never by the first timed line: once it is warm, a line with traffic runs no compilation."""
    harness = Harness(tmp_path)
    harness.warm_up()
    assert harness._warm
    before = _compiled_signatures()
    harness.run("00:00:00.00>CRE X1 EC35 40.70 -74.00 90 1500 60; ASAS ON; CRE X2 EC35 40.70 -73.99 270 1500 60")
    assert harness.failures == [] and _compiled_signatures() == before


def _compiled_signatures() -> int:
    """How many compiled signatures the Numba dispatchers of aamsim hold (compiled or loaded from the cache)."""
    import sys

    from numba.core.registry import CPUDispatcher

    count = 0
    for name, module in list(sys.modules.items()):
        if name.startswith("aamsim"):
            for value in list(vars(module).values()):
                if isinstance(value, CPUDispatcher):
                    count += len(value.overloads)
    return count


def test_batch_files_with_hostile_scen_names_and_settings() -> None:
    result = fuzz_batch(80, seed=3, run_every=20)
    assert result.cases == 80 and 0 < result.refused < 80
    assert [(f.kind, f.detail) for f in result.failures] == []


def test_uam2scn_with_hostile_fields_writes_only_flight_commands() -> None:
    result = fuzz_uam2scn(200, seed=3)
    assert result.cases == 200 and 0 < result.refused < 200
    assert [(f.kind, f.detail) for f in result.failures] == []


def test_the_viewer_websocket_answers_every_message_and_connection_as_its_policy_says() -> None:
    result = fuzz_viewer(150, seed=3, reply_s=120.0)
    assert result.cases == 150 and result.messages > 80 and result.connections > 10
    assert result.error_replies > 20 and result.refused_connections > 0
    assert [(f.kind, f.detail, f.line) for f in result.failures] == []


def test_the_fuzz_line_no_longer_fails_under_the_fuzz_harness(tmp_path: Path) -> None:
    """The scenario fuzzer's crash (tests/test_aircraft_bound.py): under the harness's 20 s alarm
    ``MCRE 100000`` was slow again alone, or a SystemError crash; now the 20,000-aircraft bound refuses it.
    In this file: the harness's warm-up of every kernel is paid once per test process."""
    harness = Harness(tmp_path)
    harness.run("00:00:00.76>MCRE 100000,")
    assert harness.failures == [] and harness.unconfirmed_slow == [] and harness.heavy_lines == 0
    assert harness._sim is not None and harness._sim.view.n == 2  # the harness's two setup aircraft
    assert "MCRE 100,000: this simulation flies at most 20,000" in [m.text for m in harness._sim.reporter.errors()][-1]
