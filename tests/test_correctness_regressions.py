"""Silent-wrong-answer regressions of issue 19 (line numbers, AT ... DO, stale conditions).

Each test failed on the code before its fix.
"""

from __future__ import annotations

import pytest
from conftest import errors_of

from aamsim import Simulation
from aamsim.stack.parser import parse_scenario, scenario_lines
from aamsim.stack.validate import validate_scenario
from aamsim.units import KTS

# Characters str.splitlines() treats as line ends but a text file reader (and BlueSky) does not.
NOT_NEWLINES = ["\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029"]


@pytest.mark.parametrize("char", NOT_NEWLINES)
def test_an_odd_character_inside_a_line_does_not_shift_later_line_numbers(char: str) -> None:
    text = f"00:00:00.00>ECHO a{char}b\n00:00:01.00>NOSUCH 1\n00:00:02.00>ALSONOT 2\n"
    parsed = parse_scenario(text, "f.scn", is_command=lambda n: n == "ECHO")
    assert [(e.source.line, e.message) for e in parsed.errors] == [(2, "unknown command NOSUCH"),
                                                                   (3, "unknown command ALSONOT")]


def test_lines_end_at_lf_crlf_and_cr_as_in_a_text_file() -> None:
    assert scenario_lines("a\nb\r\nc\rd\x0be\u2028f") == ["a", "b", "c", "d\x0be\u2028f"]
    assert scenario_lines("a\r\n", keepends=True) == ["a\r\n"]


AT_SCN = """\
00:00:00.00>CRE A001 EC35 40.70 -74.00 0 1000 60
00:00:00.00>ADDWPT A001 40.705 -74.00
00:00:00.00>ADDWPT A001 40.75 -74.00
00:00:00.00>AT A001 A001001 DO SPD A001 50
00:00:00.00>CRE B001 EC35 40.70 -73.90 0 1000 60
00:00:00.00>ADDWPT B001 40.705 -73.90
00:00:00.00>ADDWPT B001 40.75 -73.90
00:00:00.00>AT B001 B001001 DO SPD 40
"""


def test_at_do_with_and_without_the_callsign_both_work_as_in_bluesky() -> None:
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    sim.load_scenario("at.scn", text=AT_SCN)
    sim.run_until(120.0)
    assert errors_of(sim) == []
    speeds = {acid: sim.view.cas[sim.view.slot(acid)] / KTS for acid in ("A001", "B001")}
    assert speeds["A001"] == pytest.approx(50.0, abs=0.1) and speeds["B001"] == pytest.approx(40.0, abs=0.1)


def test_strict_validation_agrees_with_the_live_run_on_at_do() -> None:
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    assert validate_scenario(AT_SCN, "at.scn", sim.commands) == []
    bad = AT_SCN + "00:00:00.00>AT B001 B001001 DO SPD fast\n"
    errors = validate_scenario(bad, "at.scn", sim.commands)
    assert len(errors) == 1 and errors[0].source.line == 9


def test_an_error_of_a_stored_do_command_cites_the_at_line() -> None:
    text = AT_SCN.replace("DO SPD 40", "DO ALT B001 FL")  # 'FL' without a number fails when it runs
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    sim.load_scenario("at.scn", text=text)
    sim.run_until(120.0)
    errors = errors_of(sim)
    assert len(errors) == 1 and errors[0].startswith("at.scn:8:"), errors


def test_conditions_of_a_deleted_aircraft_do_not_fire_for_its_successor() -> None:
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    sim.stack("CRE A EC35 40.70 -74.00 0 1000 60")
    sim.stack("ATDIST A 40.80 -74.01 1 ECHO fired")  # far away: not yet
    sim.stack("DEL A; CRE A EC35 40.80 -74.01 0 1000 60")  # the new A sits on the spot
    sim.run_until(5.0)
    assert [m.text for m in sim.reporter.messages if m.kind == "echo" and "fired" in m.text] == []
    assert len(sim.conditions) == 0
