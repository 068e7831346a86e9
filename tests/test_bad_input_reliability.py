"""Scenario input that used to end or hang a run (issue 17): each is now a reported error and the run goes on.

Every case failed on the code before the fix: an exception ended the run,
or the run never ended.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from bridge_util import run_cli
from conftest import errors_of

from aamsim import Simulation
from aamsim.stack.validate import validate_scenario
from aamsim.units import MAX_TIME_S, UnitParseError, parse_altitude, parse_time

HUGE = "9" * 400
OK_LINE = "00:00:01.00>ECHO still running"


def run_text(text: str, tmp_path: Path, name: str = "bad.scn", until: float = 5.0) -> Simulation:
    path = tmp_path / name
    path.write_text(text)
    sim = Simulation(seed=1, use_bluesky_navdata=False)
    sim.files.search_path.insert(0, tmp_path)
    sim.load_scenario(path)
    sim.run_until(until)
    return sim


def echoes(sim: Simulation) -> list[str]:
    return [m.text for m in sim.reporter.messages if m.kind == "echo"]


@pytest.mark.parametrize("line, fragment", [
    (f"{HUGE}:00:00.00>ECHO x", "beyond the longest simulated time"),
    (f"00:{HUGE}:00.00>ECHO x", "beyond the longest simulated time"),
    ("00:00:1e308>ECHO x", "beyond the longest simulated time"),
    ("00:00:00.00>SCHEDULE 1e308 ECHO x", "beyond the longest simulated time"),
    ("00:00:00.00>DELAY 1e308 ECHO x", "beyond the longest simulated time"),
    (f"00:00:00.00>SCHEDULE {HUGE}:00 ECHO x", "beyond the longest simulated time"),
    ("00:00:00.00>CRE A EC35 40.7 -74 0 1000 60; ALT A FL" + HUGE, "flight level above FL2000"),
    ("00:00:00.00>PCALL .", '"." is not a file name'),
    # Found by the fuzzing harness (tests/fuzz): an IndexError and a ValueError escaped.
    ("00:00:00.00>CRE A EC35 40.7 -74 0 1000 60; RTA A * 01:00:00", "A has no waypoint * in its route"),
    ("00:00:00.00>SEED -1", "SEED must be a whole number from 0, not -1"),
    ("00:00:00.00>CRE A EC35 40.7 -74 0 1000 60; SEPVOLUME LOWC 1e308", "at most 1e+06 m"),
    ("00:00:00.00>ZONER 1e308", "protected-zone radius must be positive and at most 1e+06 m"),
    ("00:00:00.00>ZONEDH 1e308", "protected-zone height must be positive and at most 1e+06 m"),
    ("00:00:00.00>DTLOOK 1000000", "look-ahead time must be positive and at most 86400 s"),
    ("00:00:00.00>PCALL ..", '".." is not a file name'),
])
def test_numbers_and_names_beyond_range_are_line_errors(tmp_path: Path, line: str, fragment: str) -> None:
    sim = run_text(f"{line}\n{OK_LINE}\n", tmp_path)
    errors = errors_of(sim)
    assert len(errors) == 1 and errors[0].startswith(f"{tmp_path / 'bad.scn'}:1:") and fragment in errors[0], errors
    assert echoes(sim) == ["still running"]


def test_a_directory_is_not_a_scenario_file(tmp_path: Path) -> None:
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub.scn").mkdir()
    sim = run_text(f"00:00:00.00>PCALL sub\n00:00:00.00>IC sub\n{OK_LINE}\n", tmp_path)
    errors = errors_of(sim)
    assert len(errors) == 2 and all("not found: sub" in e for e in errors), errors
    assert echoes(sim) == ["still running"]


def test_a_file_that_pcalls_itself_is_a_reported_cycle(tmp_path: Path) -> None:
    sim = run_text(f"00:00:00.00>PCALL loop.scn\n{OK_LINE}\n", tmp_path, "loop.scn")
    errors = errors_of(sim)
    assert errors and "PCALL loop.scn: the files call each other in a cycle (loop.scn -> loop.scn)" in errors[0]
    assert echoes(sim) == ["still running"]


def test_two_files_pcalling_each_other_report_the_chain(tmp_path: Path) -> None:
    (tmp_path / "b.scn").write_text("00:00:00.00>PCALL a.scn\n00:00:00.00>ECHO in b\n")
    sim = run_text(f"00:00:00.00>PCALL b.scn\n{OK_LINE}\n", tmp_path, "a.scn")
    errors = errors_of(sim)
    assert len(errors) == 1 and "cycle (a.scn -> b.scn -> a.scn)" in errors[0], errors
    assert echoes(sim) == ["in b", "still running"]


def test_deep_but_finite_pcall_chains_are_limited(tmp_path: Path) -> None:
    for k in range(30):
        (tmp_path / f"f{k}.scn").write_text(f"00:00:00.00>PCALL f{k + 1}.scn\n")
    sim = run_text("00:00:00.00>PCALL f0.scn\n" + OK_LINE + "\n", tmp_path, "top.scn")
    errors = errors_of(sim)
    assert len(errors) == 1 and "nested more than 16 deep" in errors[0] and "top.scn -> f0.scn" in errors[0]
    assert echoes(sim) == ["still running"]


@pytest.mark.parametrize("when", ["00:00:00.00", "00:00:01.00"])
def test_ic_of_the_running_file_is_a_cycle_not_an_endless_reset(tmp_path: Path, when: str) -> None:
    sim = run_text(f"{when}>IC self.scn\n00:00:02.00>ECHO after\n", tmp_path, "self.scn")
    errors = errors_of(sim)
    assert len(errors) == 1 and "IC self.scn: the files call each other in a cycle" in errors[0], errors
    assert echoes(sim) == ["after"]


def test_files_that_ic_each_other_are_a_cycle(tmp_path: Path) -> None:
    (tmp_path / "g.scn").write_text("00:00:00.00>IC f.scn\n00:00:01.00>ECHO in g\n")
    sim = run_text("00:00:00.00>IC g.scn\n", tmp_path, "f.scn")
    errors = errors_of(sim)
    assert len(errors) == 1 and "cycle (f.scn -> g.scn -> f.scn)" in errors[0], errors
    assert echoes(sim) == ["in g"]


def test_two_thousand_nested_schedules_under_strict_are_one_error() -> None:
    sim = Simulation(use_bluesky_navdata=False)
    text = "00:00:00.00>" + "SCHEDULE 1 " * 2000 + "ECHO deep\n00:00:00.00>NOSUCH 1\n"
    errors = validate_scenario(text, "deep.scn", sim.commands)
    assert [e.source.line for e in errors] == [1, 2]
    assert "nested more than 50 deep" in errors[0].message


def test_strict_run_lists_every_error_and_exits_2(tmp_path: Path) -> None:
    (tmp_path / "bad.scn").write_text(f"{HUGE}:00:00.00>ECHO x\n00:00:00.00>SCHEDULE 1e308 ECHO x\n"
                                      "00:00:00.00>PCALL .\n00:00:00.00>ECHO fine\n")
    proc = run_cli("run", "bad.scn", "--strict", "--quiet", cwd=tmp_path)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert [ln.split(":")[1] for ln in proc.stderr.splitlines() if ln.startswith("bad.scn:")][:3] == ["1", "2", "3"]
    assert "bad.scn: 3 error(s); nothing simulated (--strict)" in proc.stderr


def test_a_run_with_every_bad_line_goes_on_to_the_end(tmp_path: Path) -> None:
    (tmp_path / "loop.scn").write_text("00:00:00.00>PCALL loop.scn\n")
    lines = [f"{HUGE}:00:00.00>ECHO x", "00:00:00.00>SCHEDULE 1e308 ECHO x", "00:00:00.00>DELAY 1e308 ECHO x",
             "00:00:00.00>PCALL /tmp", "00:00:00.00>PCALL .", "00:00:00.00>PCALL loop.scn",
             "00:00:00.00>CRE A EC35 40.7 -74 0 1000 60", "00:00:00.00>ALT A FL" + HUGE, "00:00:30.00>ECHO done"]
    (tmp_path / "all.scn").write_text("\n".join(lines) + "\n")
    proc = run_cli("run", "all.scn", "--until", "60", "--out", "out", "--log-period", "0", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr and "done" in proc.stderr
    assert "errors: 7" in proc.stdout


def test_time_and_altitude_parsers_state_their_ranges() -> None:
    assert parse_time("876600:00:00") == pytest.approx(876600 * 3600.0)
    with pytest.raises(UnitParseError, match="100 years"):
        parse_time(f"{int(MAX_TIME_S // 3600) + 1}:00:00")
    assert parse_altitude("FL2000") == pytest.approx(200_000 * 0.3048)
    with pytest.raises(UnitParseError, match="above FL2000"):
        parse_altitude("FL2001")
    for text in ("-1e6", "1.55e7", "200001"):
        with pytest.raises(UnitParseError, match="altitude outside -2,000 .. 200,000 ft"):
            parse_altitude(text)
