"""A fan-out of PCALLs is bounded and a stop request ends it (issue 26, item 6).

Ten files each PCALLing the next ten times expand tenfold per level, all at one sim time: ``aamsim
run`` used to ignore SIGINT and SIGTERM while they loaded (the stop was checked between steps only)
and grew by a gigabyte a minute.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from aamsim import Simulation
from aamsim.errors import SourceRef
from aamsim.stack.commands import sim_cmds
from aamsim.stack.parser import Command, TimedCommand
from aamsim.stack.queue import CommandQueue

ROOT = Path(__file__).resolve().parents[1]


def write_fanout(folder: Path, levels: int, fan: int = 10, first: str = "") -> Path:
    """f0.scn .. f<levels>.scn: each PCALLs the next ``fan`` times; the last echoes."""
    for k in range(levels):
        lines = [first] if first and k == 0 else []
        lines += [f"00:00:00.00>PCALL f{k + 1}.scn"] * fan
        (folder / f"f{k}.scn").write_text("\n".join(lines) + "\n")
    (folder / f"f{levels}.scn").write_text("00:00:00.00>ECHO leaf\n")
    return folder / "f0.scn"


def test_the_files_pcall_loads_are_bounded_with_ten_errors_then_notes(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sim_cmds, "MAX_PCALL_FILES", 50)  # the mechanism at a size a test can count
    sim = Simulation(use_bluesky_navdata=False)
    sim.load_scenario(write_fanout(tmp_path, 4))
    sim.run_until(0.0)
    # Round 1: 10 PCALL f1 load (10 files, 100 commands); round 2: 40 of the 100 PCALL f2 load (50 files),
    # 60 are refused; round 3: the 400 PCALL f3 that loaded are all refused: 460 refusals.
    assert (sim.files.pcall_files, sim.files.pcall_commands, sim.files.pcall_refused) == (50, 500, 460)
    errors = [m.text for m in sim.reporter.errors()]
    assert len(errors) == 10 and all("f2.scn: refused, PCALL has loaded 50 files since the scenario started"
                                     in e for e in errors)
    notes = [m.text for m in sim.reporter.messages if m.kind == "note" and "PCALLs refused" in m.text]
    assert notes == ["100 PCALLs refused so far: PCALL has loaded 50 files since the scenario started"]
    assert len(sim.queue) == 0


def test_the_commands_pcall_queues_are_bounded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sim_cmds, "MAX_PCALL_COMMANDS", 250)
    sim = Simulation(use_bluesky_navdata=False)
    sim.load_scenario(write_fanout(tmp_path, 4))
    sim.run_until(0.0)
    # 10 loads of f1 queue 100 commands; 15 of f2 take it to 250; the 16th would pass: the budget is spent.
    assert (sim.files.pcall_files, sim.files.pcall_commands) == (25, 250)
    assert "PCALL has queued 250 commands since the scenario started" in sim.reporter.errors()[0].text
    sim.reset()  # a new scenario: the budget starts again
    assert (sim.files.pcall_files, sim.files.pcall_commands, sim.files.pcall_refused) == (0, 0, 0)


@pytest.mark.slow
def test_the_default_budget_stops_a_ten_level_fanout(tmp_path: Path) -> None:
    """With the shipped bounds: 10,000 files loaded at most, the rest refused, nothing left queued."""
    sim = Simulation(use_bluesky_navdata=False)
    sim.load_scenario(write_fanout(tmp_path, 10))
    sim.run_until(0.0)
    assert sim.files.pcall_files == sim_cmds.MAX_PCALL_FILES and len(sim.queue) == 0
    assert sim.files.pcall_refused > 0 and len(sim.reporter.errors()) == 10


def test_a_stop_request_ends_the_loading_with_the_rest_still_queued(tmp_path: Path) -> None:
    sim = Simulation(use_bluesky_navdata=False)
    sim.load_text("00:00:00.00>ECHO one\n00:00:00.00>QUIT\n00:00:00.00>ECHO two\n00:00:00.00>ECHO three\n", "q.scn")
    sim.run_until(10.0)
    assert sim.simt == 0.0 and [m.text for m in sim.reporter.messages if m.kind == "echo"] == ["one"]
    assert [c.command.argtext for c in sim.queue.pending()] == ["two", "three"]  # in their order


def test_push_front_puts_commands_back_ahead_of_those_due_at_the_same_time() -> None:
    queue = CommandQueue()
    src = SourceRef("x", 1)
    make = [TimedCommand(0.0, Command(name.upper(), ""), src) for name in "abcd"]
    queue.push(make[2])
    queue.push(TimedCommand(5.0, Command("LATE", ""), src))
    queue.push_front([make[0], make[1]])
    queue.push(make[3])
    assert [c.command.name for c in queue.pending()] == ["A", "B", "C", "D", "LATE"]


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_during_a_pcall_fanout_ends_the_run_with_its_outputs(tmp_path: Path, signum: int,
                                                                      code: int) -> None:
    scenario = write_fanout(tmp_path, 10, first="00:00:00.00>ECHO fanning out")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "aamsim", "run", str(scenario), "--out", "out"], cwd=tmp_path,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr is not None
        for line in proc.stderr:  # the ECHO comes before the first PCALL: loading has begun
            if "fanning out" in line:
                break
        proc.send_signal(signum)
        _, stderr = proc.communicate(timeout=120)  # the old code went on loading 10^10 lines
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == code, stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["interrupted_by"] == signal.Signals(signum).name and summary["sim_time_s"] == 0.0
