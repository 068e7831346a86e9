"""The bound on aircraft flying at once in a local simulation (``aamsim run --max-aircraft``, ``Simulation(max_aircraft=...)``).

The scenario fuzzer found ``00:00:00.76>MCRE 100000,``: a local run had no bound, so the line made
100,000 aircraft (2 s of sim time took 28 s of wall time), and under the fuzz harness's 20 s alarm
the run ended with ``SystemError: CPUDispatcher(<function detect_all>) returned a result with an
exception set`` (see tests/test_compiled_errors.py for that half).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.limits import DEFAULT_LOCAL_MAX_AIRCRAFT
from tests.bridge_util import run_cli

FUZZ_LINE = "00:00:00.76>MCRE 100000,"


def _errors(sim: Simulation) -> list[str]:
    return [m.text for m in sim.reporter.errors()]


def test_mcre_past_the_bound_is_refused_whole_saying_how_many_fit() -> None:
    sim = Simulation(use_bluesky_navdata=False, max_aircraft=50)
    sim.stack("CRE A1 EC35 40.7 -74.0 0 1500 60; CRE A2 EC35 40.7 -74.1 0 1500 60")
    sim.run_until(0.5)
    sim.stack("MCRE 49")
    assert sim.view.n == 2  # none of the 49 was created
    (error,) = _errors(sim)
    assert ("MCRE 49: this simulation flies at most 50 aircraft at once, and 2 fly at t = 0.50 s: 48 more fit; "
            "none created") in error
    assert "aamsim run --max-aircraft" in error
    sim.stack("MCRE 48")
    assert sim.view.n == 50 and len(_errors(sim)) == 1
    sim.stack("CRE A3 EC35 40.7 -74.2 0 1500 60")
    assert "A3" not in sim.view and sim.view.n == 50
    assert "A3: this simulation flies at most 50 aircraft at once, and 50 fly at t = 0.50 s" in _errors(sim)[-1]


def test_the_default_bound_refuses_the_fuzz_line_and_the_run_goes_on() -> None:
    sim = Simulation(use_bluesky_navdata=False)
    assert sim.limits.max_aircraft == DEFAULT_LOCAL_MAX_AIRCRAFT == 20_000
    sim.load_text(FUZZ_LINE + "\n00:00:01.00>CRE A1 EC35 40.7 -74.0 0 1500 60\n", "fuzz.scn")
    sim.run_until(2.0)
    assert sim.view.n == 1 and "A1" in sim.view  # the line after the refused one ran
    (error,) = sim.reporter.errors()
    assert error.source is not None and (error.source.path, error.source.line) == ("fuzz.scn", 1)
    # 0.76 s runs at the first step boundary at or after it, as in BlueSky
    assert "MCRE 100,000: this simulation flies at most 20,000 aircraft at once, and 0 fly at t = 0.80 s: 20,000 " \
           "more fit; none created" in error.text


def test_reset_keeps_the_bound_and_none_lifts_it() -> None:
    sim = Simulation(use_bluesky_navdata=False, max_aircraft=3)
    sim.stack("RESET")
    sim.stack("MCRE 4")
    assert sim.view.n == 0 and "3 more fit" in _errors(sim)[-1]
    unbounded = Simulation(use_bluesky_navdata=False, max_aircraft=None)
    assert unbounded.limits.room(10**9) is None


@pytest.mark.parametrize("bad", [0, -1, 2.5, True, "10"])
def test_a_bound_that_is_not_a_whole_number_of_at_least_one_is_refused(bad: object) -> None:
    with pytest.raises(ValueError, match="max_aircraft must be a whole number of at least 1"):
        Simulation(use_bluesky_navdata=False, max_aircraft=bad)  # type: ignore[arg-type]


def test_cre_lines_of_a_pcalled_file_past_the_bound_are_reported_with_their_lines(tmp_path: Path) -> None:
    (tmp_path / "more.scn").write_text("".join(f"00:00:00.00>CRE B{k} EC35 40.7 -74.{k} 0 1500 60\n"
                                               for k in range(4)))
    sim = Simulation(use_bluesky_navdata=False, max_aircraft=3)
    sim.files.search_path.insert(0, tmp_path)
    sim.load_text("00:00:00.00>CRE A1 EC35 40.7 -73.9 0 1500 60\n00:00:00.00>PCALL more.scn\n", "main.scn")
    sim.run_until(1.0)
    assert sorted(sim.view.ids) == ["A1", "B0", "B1"]
    refused = sim.reporter.errors()
    assert [(Path(e.source.path).name, e.source.line) for e in refused if e.source] == [("more.scn", 3),
                                                                                        ("more.scn", 4)]
    assert all("flies at most 3 aircraft at once" in e.text for e in refused)


@settings(max_examples=40, deadline=None)
@given(bound=st.integers(1, 30),
       commands=st.lists(st.one_of(st.integers(1, 25).map(lambda k: f"MCRE {k}"), st.just("CRE"), st.just("DEL *")),
                         max_size=12))
def test_no_sequence_of_creations_passes_the_bound_and_every_refusal_is_reported(bound: int,
                                                                                 commands: list[str]) -> None:
    sim = Simulation(use_bluesky_navdata=False, max_aircraft=bound)
    flying = refused = 0
    for k, command in enumerate(commands):
        if command == "DEL *":
            sim.stack("DEL *")
            flying = 0
            continue
        count = 1 if command == "CRE" else int(command.split()[1])
        sim.stack(f"CRE C{k} EC35 40.7 -74.0 0 1500 60" if command == "CRE" else command)
        if flying + count <= bound:
            flying += count  # an MCRE that fits creates all it asked for
        else:
            refused += 1  # one that does not creates none, with one error
        assert sim.view.n == flying <= bound
        assert len(sim.reporter.errors()) == refused


def test_aamsim_run_reports_an_mcre_over_the_bound_with_its_line_and_goes_on(tmp_path: Path) -> None:
    scenario = tmp_path / "s.scn"
    scenario.write_text("00:00:00.00>CRE A1 EC35 40.7 -74.0 0 1500 60\n"
                        "00:00:00.50>MCRE 40 EC35 1500 60\n"
                        "00:00:01.00>MCRE 29 EC35 1500 60\n"
                        "00:00:01.50>CRE A2 EC35 40.7 -74.1 0 1500 60\n")
    out = tmp_path / "run"
    proc = run_cli("run", str(scenario), "--until", "3", "--out", str(out), "--max-aircraft", "30", "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert (f"{scenario}:2: error: MCRE: MCRE 40: this simulation flies at most 30 aircraft at once, and 1 fly at "
            "t = 0.50 s: 29 more fit; none created; a limit of this simulation (aamsim run --max-aircraft N") \
        in proc.stderr
    assert f"{scenario}:4: error: CRE: A2: this simulation flies at most 30 aircraft at once, and 30 fly" in proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["errors"] == 2 and summary["aircraft_at_end"] == 30 and summary["sim_time_s"] == 3.0


def test_aamsim_run_refuses_the_fuzz_line_by_default(tmp_path: Path) -> None:
    scenario = tmp_path / "fuzz.scn"
    scenario.write_text(FUZZ_LINE + "\n")
    out = tmp_path / "run"
    proc = run_cli("run", str(scenario), "--until", "2", "--out", str(out), "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert f"{scenario}:1: error: MCRE: MCRE 100,000: this simulation flies at most 20,000 aircraft" in proc.stderr
    assert json.loads((out / "summary.json").read_text())["flights_created"] == 0


def test_max_aircraft_must_be_at_least_one(tmp_path: Path) -> None:
    proc = run_cli("run", "scn/demo.scn", "--max-aircraft", "0", "--out", str(tmp_path / "run"))
    assert proc.returncode == 2 and "Invalid value for '--max-aircraft'" in proc.stderr
