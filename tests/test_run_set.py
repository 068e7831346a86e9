"""``aamsim run --set``: a service switched on for one run, so that aamsim compare pairs it with the
unequipped run of the same scenario file (issue 30, item 7)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TINY = str(ROOT / "tests" / "data" / "tiny_conflict.scn")


def aamsim(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "aamsim", *args], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=600, check=False)


def test_equipped_run_of_the_same_file_compares_with_the_unequipped_one(tmp_path):
    for name, extra in (("unequipped", ()), ("daa", ("--set", "stack=RESO DAA"))):
        proc = aamsim("run", TINY, "--seed", "1", "--out", name, "--quiet", *extra, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
    daa = json.loads((tmp_path / "daa" / "summary.json").read_text())
    unequipped = json.loads((tmp_path / "unequipped" / "summary.json").read_text())
    assert daa["commands"] == ["RESO DAA"] and unequipped["commands"] == []
    assert daa["scenario_sha256"] == unequipped["scenario_sha256"]  # the file's text, not the added command
    assert (tmp_path / "daa" / "scenario.scn").read_text() == Path(TINY).read_text()
    # tiny_conflict: unequipped, one NMAC at the merge; DAA separates the two aircraft (docs/daa.md).
    assert unequipped["safety"]["nmac_events"] == 1 and daa["safety"]["nmac_events"] == 0
    assert daa["daa"]["advisories_issued"] > 0
    proc = aamsim("compare", "daa", "unequipped", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "risk ratio (NMAC): 0.0000" in proc.stdout
    comparison = json.loads((tmp_path / "daa" / "comparison.json").read_text())
    assert comparison["risk_ratio"]["pooled"] == 0.0


def test_several_stack_commands_run_in_order_and_other_keys_replace_options(tmp_path):
    proc = aamsim("run", TINY, "--out", "r", "--quiet", "--set", "stack=ECHO first", "--set", "stack=ECHO second",
                  "--set", "until=30", "--set", "dt=0.1", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["commands"] == ["ECHO first", "ECHO second"]
    assert summary["sim_time_s"] == 30.0 and summary["dt_s"] == 0.1
    log = (tmp_path / "r" / "messages.log").read_text()
    assert log.index("first") < log.index("second")


def test_a_volume_given_by_set_replaces_its_option_and_leaves_the_other(tmp_path):
    proc = aamsim("run", TINY, "--out", "r", "--quiet", "--until", "10", "--lowc", "600", "--set", "nmac=100",
                  cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    volumes = json.loads((tmp_path / "r" / "summary.json").read_text())["separation_volumes"]
    assert "r=100 m" in volumes["nmac"] and "r=600 m" in volumes["lowc"]


def test_a_bad_setting_is_refused_before_the_run(tmp_path):
    proc = aamsim("run", TINY, "--out", "r", "--set", "lowc=wide", cwd=tmp_path)
    assert proc.returncode == 2 and "--set" in proc.stderr and "lowc" in proc.stderr
    proc = aamsim("run", TINY, "--out", "r", "--set", "dt=0.1", "--set", "dt=0.2", cwd=tmp_path)
    assert proc.returncode == 2 and "aamsim batch" in proc.stderr
    proc = aamsim("run", TINY, "--out", "r", "--set", "colour=red", cwd=tmp_path)
    assert proc.returncode == 2 and "unknown key 'colour'" in proc.stderr
    assert not (tmp_path / "r").exists()
