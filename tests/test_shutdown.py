"""Ctrl-C or SIGTERM in the middle of ``aamsim run`` leaves a complete, readable run directory (issue 17)."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def read_rows(path: Path) -> list[list[str]]:
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.reader(fh))


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_an_interrupted_run_writes_a_consistent_run_directory(tmp_path: Path, signum: int, code: int) -> None:
    out = tmp_path / "run"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "aamsim", "run", "scn/nyc_day.scn", "--out", str(out), "--quiet"],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        trajectories = out / "trajectories.csv"
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and proc.poll() is None:
            if trajectories.exists() and trajectories.stat().st_size > 200_000:  # midway: rows written
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the run ended before it could be interrupted"
        proc.send_signal(signum)
        _, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == code, stderr
    assert f"{signal.Signals(signum).name}: stopped at sim time" in stderr and "Traceback" not in stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interrupted"] is True and summary["interrupted_by"] == signal.Signals(signum).name
    assert 0 < summary["sim_time_s"] < 86_400 and summary["flights_created"] < 4051
    assert "safety" in summary and "operational" in summary
    rows = read_rows(trajectories)
    assert len(rows) > 1000 and all(len(r) == len(rows[0]) for r in rows)  # no half-written row
    assert max(float(r[1]) for r in rows[1:]) <= summary["sim_time_s"] + 1e-6
    flights = read_rows(out / "flights.csv")
    assert len(flights) - 1 == summary["flights_created"] and all(len(r) == len(flights[0]) for r in flights)
    assert all(len(r) == len(read_rows(out / "conflicts.csv")[0]) for r in read_rows(out / "conflicts.csv"))
    assert "run stopped at sim time" in (out / "messages.log").read_text()


def test_a_run_that_ends_by_itself_is_not_interrupted(tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "aamsim", "run", "scn/demo.scn", "--out", "r", "--quiet"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    assert json.loads((tmp_path / "r" / "summary.json").read_text())["interrupted"] is False
