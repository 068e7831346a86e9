"""A run killed outright (SIGKILL) still leaves a summary.json, marked incomplete (issue 26 item 10).

``aamsim run`` writes a provisional summary before the first step and every few
seconds of wall time after (atomically), ``"complete": false``; the final one
replaces it. The readers of summaries refuse (compare, batch aggregation) or
warn about (view) a provisional one.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from aamsim.batch.aggregate import flatten_metrics
from aamsim.output.summary_file import IncompleteSummary, ProvisionalSummary, write_json_atomic

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))


def aamsim(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "aamsim", *args], cwd=cwd, env=ENV, capture_output=True, text=True,
                          timeout=600, check=False)


def read_summary(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


@pytest.fixture(scope="module")
def killed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``aamsim run scn/nyc_day.scn`` killed with SIGKILL once its summary shows it under way."""
    tmp = tmp_path_factory.mktemp("killed")
    out = tmp / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "aamsim", "run", "scn/nyc_day.scn", "--out", str(out), "--quiet",
                             "--log-period", "10"], cwd=tmp, env=ENV, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    try:
        # Wait (no limit asserted: the machine may be slow) until a periodic update shows sim time
        # going on; the run of the whole day lasts much longer than that.
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline and proc.poll() is None:
            summary = read_summary(out / "summary.json")
            if summary is not None and summary["flights_created"] > 0:
                break
            time.sleep(0.2)
        assert proc.poll() is None, "the run ended before it could be killed: " + proc.stderr.read().decode()[-2000:]
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    return out


def test_a_killed_run_leaves_a_provisional_summary(killed_run: Path) -> None:
    summary = json.loads((killed_run / "summary.json").read_text())
    assert summary["complete"] is False
    assert summary["scenario"] == "nyc_day" and summary["dt_s"] == 0.05
    assert 0 < summary["sim_time_s"] < 86_400 and summary["flights_created"] > 0
    assert summary["aircraft_steps"] > 0 and summary["wall_time_s"] > 0
    assert not (killed_run / "flights.csv").exists()  # the end never came: only the summary tells
    # The trajectory rows up to the summary's time were on disk (written before it).
    rows = (killed_run / "trajectories.csv").read_text().splitlines()
    assert rows[0].startswith("id,simt,") and len(rows) > 1
    assert [p.name for p in killed_run.iterdir() if p.name.endswith(".tmp")] == []


def test_compare_refuses_a_killed_run(killed_run: Path, tmp_path: Path) -> None:
    proc = aamsim("compare", str(killed_run), str(killed_run), cwd=tmp_path)
    assert proc.returncode == 2
    assert "the run did not finish" in proc.stderr and "summary.json" in proc.stderr


def test_batch_aggregation_refuses_a_provisional_summary(killed_run: Path) -> None:
    summary = json.loads((killed_run / "summary.json").read_text())
    with pytest.raises(IncompleteSummary, match="the run did not finish"):
        flatten_metrics(summary)
    # Final summaries, and those of runs made before provisional summaries existed, still count.
    assert flatten_metrics({**summary, "complete": True})["sim_time_s"] == summary["sim_time_s"]
    assert "sim_time_s" in flatten_metrics({k: v for k, v in summary.items() if k != "complete"})


def test_view_of_a_killed_run_warns_and_shows_what_it_wrote(killed_run: Path, tmp_path: Path) -> None:
    proc = aamsim("view", str(killed_run), "--video", str(tmp_path / "killed.gif"), "--size", "200x200",
                  "--speed", "600", cwd=tmp_path)
    assert "warning:" in proc.stderr and "the run did not finish" in proc.stderr
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "killed.gif").stat().st_size > 0


def test_the_final_summary_replaces_the_provisional_one(tmp_path: Path) -> None:
    proc = aamsim("run", "scn/nyc_train_100.scn", "--until", "60", "--out", "done", "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "done" / "summary.json").read_text())
    assert summary["complete"] is True and summary["ended_by"] == "until" and "safety" in summary
    assert sorted(p.name for p in (tmp_path / "done").iterdir() if p.name.startswith(".")) == []


def test_provisional_writes_are_periodic_and_atomic(tmp_path: Path) -> None:
    now = [100.0]
    made: list[float] = []

    def make(wall_s: float) -> dict:
        made.append(wall_s)
        return {"sim_time_s": wall_s * 10}

    path = tmp_path / "summary.json"
    prov = ProvisionalSummary(path, make, lambda kind, text: None, period_s=5.0, clock=lambda: now[0])
    prov.write(0.0)
    for wall in (1.0, 4.9, 5.0, 7.0, 10.1):
        now[0] = 100.0 + wall
        prov.maybe_write(wall)
    assert made == [0.0, 5.0, 10.1] and prov.writes == 3
    assert json.loads(path.read_text()) == {"sim_time_s": 101.0, "complete": False}
    write_json_atomic(path, {"complete": True})
    assert json.loads(path.read_text()) == {"complete": True} and list(tmp_path.iterdir()) == [path]


def test_a_provisional_summary_that_cannot_be_written_is_a_warning(tmp_path: Path) -> None:
    reports: list[tuple[str, str]] = []
    prov = ProvisionalSummary(tmp_path / "missing" / "summary.json", lambda wall: {}, lambda k, t: reports.append((k, t)))
    prov.write(0.0)
    prov.write(1.0)
    assert prov.writes == 0 and len(reports) == 1 and reports[0][0] == "warning"
