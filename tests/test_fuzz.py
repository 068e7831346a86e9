"""A short run of the scenario fuzzing harness (the long one: ``python -m tests.fuzz --lines 1000000``).

No line may end the run with an exception; the time budget is generous here
because CI machines are shared (the long run reports lines over 1 s).
"""

from __future__ import annotations

import logging
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.stack.parser import parse_scenario
from tests.fuzz.scenario import TYPE_VALUES, WORDS, Harness, LineMaker

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
