"""``aamsim run`` on a full disk, and messages that reach the terminal (issue 26, item 8).

A full disk ended the run with a traceback, no ``summary.json`` and a half-written last row of
``trajectories.csv`` (which ``aamsim view`` then refused); ``ECHO`` passed raw control bytes (terminal
escape sequences) through to the terminal.
"""

from __future__ import annotations

import csv
import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.messages import printable
from aamsim.output.recorder import TrajectoryRecorder
from aamsim.viewer.frames import RunReplay

ROOT = Path(__file__).resolve().parents[1]
FILE_LIMIT_BYTES = 100_000


def _small_file_limit() -> None:
    """In the child: files may grow to 100 kB, and a write past that fails (EFBIG) instead of killing it."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_LIMIT_BYTES, FILE_LIMIT_BYTES))


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(resource, "RLIMIT_FSIZE"), reason="needs POSIX file-size limits")
def test_a_file_that_cannot_be_written_ends_the_run_with_a_message_and_whole_rows(tmp_path: Path) -> None:
    (tmp_path / "s.scn").write_text("00:00:00.00>MCRE 20 EC35 500 60\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    args = [sys.executable, "-m", "aamsim", "run", "s.scn", "--until", "600", "--quiet", "--seed", "1", "--out"]
    # Once without the limit: Numba's cache of compiled kernels is written then (the limit would refuse it),
    # and the trajectories are known to be over the limit.
    free = subprocess.run([*args, "free"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
                          check=False)
    assert free.returncode == 0 and (tmp_path / "free" / "trajectories.csv").stat().st_size > FILE_LIMIT_BYTES
    proc = subprocess.run([*args, "out"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
                          preexec_fn=_small_file_limit, check=False)
    assert "Traceback" not in proc.stderr, proc.stderr
    assert proc.returncode == 1
    assert "trajectories.csv: cannot write (File too large)" in proc.stderr
    assert "an output file could not be written" in proc.stderr
    out = tmp_path / "out"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["errors"] >= 1 and summary["flights_created"] == 20
    raw = (out / "trajectories.csv").read_bytes()
    assert raw.endswith(b"\n") and len(raw) <= FILE_LIMIT_BYTES
    with open(out / "trajectories.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert all(len(r) == len(rows[0]) for r in rows)  # no half-written row
    RunReplay(out)  # and the run directory replays
    assert "cannot write" in (out / "messages.log").read_text()


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_a_recorder_whose_disk_is_full_stops_the_run_with_an_error() -> None:
    sim = Simulation(use_bluesky_navdata=False)
    sim.services.start()
    recorder = TrajectoryRecorder(Path("/dev/full"), 1.0)  # every write: ENOSPC
    recorder.attach(sim)
    sim.stack("MCRE 5")
    sim.run(until_s=600.0)
    recorder.close()
    assert recorder.failed == os.strerror(28) and sim.simt == 0.0
    assert "trajectories.csv" not in sim.reporter.errors()[0].text  # names the file it was given
    assert "full: cannot write (No space left on device)" in sim.reporter.errors()[0].text


def test_echo_never_sends_control_characters_to_the_terminal(tmp_path: Path) -> None:
    line = "00:00:00.00>ECHO \x1b[2J\x1b]0 title\x07 red\x1b[31m \u202etxt.exe\x9b done\n"
    (tmp_path / "e.scn").write_text(line, encoding="utf-8")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "aamsim", "run", "e.scn", "--out", "out"], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr
    assert "\\x1b[2J\\x1b]0 title\\x07 red\\x1b[31m \\u202etxt.exe\\x9b done" in proc.stderr
    everything = proc.stdout + proc.stderr + (tmp_path / "out" / "messages.log").read_text()
    assert not any(ch in everything for ch in "\x1b\x07\x9b\u202e")


@given(st.text())
def test_printable_leaves_no_control_character_but_line_feeds_and_tabs(text: str) -> None:
    shown = printable(text)
    assert all(ch in "\n\t" or not (ord(ch) < 32 or 0x7f <= ord(ch) <= 0x9f or ch in "\u202a\u202b\u202c\u202d"
                                    "\u202e\u2066\u2067\u2068\u2069") for ch in shown)
    if text.isprintable():
        assert shown == text


def test_a_file_written_in_many_blocks_is_the_file_written_in_one(tmp_path: Path) -> None:
    """Blocks of 7 rows (the writer thread formats one while the next is sampled) give the same bytes."""
    files = {}
    for name, block_rows in (("one", 10**9), ("many", 7)):
        sim = Simulation(seed=1, use_bluesky_navdata=False)  # the same aircraft in both
        sim.services.start()
        recorder = TrajectoryRecorder(tmp_path / f"{name}.csv", 1.0, block_rows=block_rows)
        recorder.attach(sim)
        sim.stack("MCRE 5 EC35 500 60")
        sim.run(until_s=40.0)
        recorder.close()
        files[name] = (tmp_path / f"{name}.csv").read_bytes()
        assert recorder.rows_written == 5 * 41  # the samples at 0, 1, ..., 40 s
    assert files["many"] == files["one"]
    assert files["one"].count(b"\n") == 1 + 5 * 41



def test_conflicts_csv_from_the_compiled_writer_is_the_csv_modules_file(tmp_path: Path, monkeypatch) -> None:
    """conflicts.csv is formatted by compiled code (Python's rounding, tests/test_fastcsv.py); the file is
    byte for byte the one the csv module writes. A volume name that needs quotes takes the csv module."""
    import dataclasses

    from aamsim.metrics import service

    sim = Simulation(seed=1)
    sim.services.start()
    sim.load_scenario(Path(__file__).parent / "data" / "daa_encounters.scn")
    sim.run(until_s=300.0)
    events = list(sim.services.conflicts.events)
    assert sorted(e.volume for e in events) == ["lowc", "lowc", "lowc", "nmac", "nmac"]

    def write(name: str, rows: list) -> bytes:
        assert service.write_conflicts_csv(tmp_path / name, sim, rows) == len(rows)
        return (tmp_path / name).read_bytes()

    renamed = [*events, dataclasses.replace(events[0], volume="lowc, 600 m", start_s=-0.125, end_s=float("nan"))]
    compiled, compiled_renamed = write("compiled.csv", events), write("renamed.csv", renamed)
    with monkeypatch.context() as m:
        m.setattr(service, "format_csv_table", lambda *args: None)
        assert write("module.csv", events) == compiled
        assert write("module_renamed.csv", renamed) == compiled_renamed
    rows = list(csv.DictReader(compiled_renamed.decode().splitlines()))
    assert rows[0]["volume"] == "lowc, 600 m" and rows[0]["start_s"] == "-0.12" and rows[0]["end_s"] == ""
    assert compiled.count(b"\r\n") == 6 and write("none.csv", []) == compiled.split(b"\r\n")[0] + b"\r\n"
