"""End-to-end: the CLIs run as a user runs them (subprocesses)."""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def aamsim(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "aamsim", *args], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=600)


def test_run_shipped_scenario_writes_run_directory(tmp_path):
    out = tmp_path / "run"
    proc = aamsim("run", "scn/demo.scn", "--out", str(out), "--seed", "3", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    for name in ("scenario.scn", "flights.csv", "trajectories.csv", "summary.json", "conflicts.csv", "messages.log"):
        assert (out / name).exists(), name
    assert "flights created" in proc.stdout and "speed-up" in proc.stdout
    assert re.search(r"safety: \d+ NMAC, \d+ LoWC events, min separation (\d+\.\d|-) m\n", proc.stdout)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["flights_created"] == 3 and summary["seed"] == 3
    assert set(summary["safety"]) >= {"nmac_events", "lowc_events", "min_separation_m", "time_in_lowc_s",
                                      "nmac_per_flight", "nmac_per_flight_hour"}
    assert set(summary["operational"]) >= {"airborne_holding_s", "alert_rate_per_flight_hour", "flights_completed",
                                           "throughput_per_hour", "distance_flown_m", "mean_delay_s"}
    with open(out / "flights.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == ["id", "type", "created_s", "deleted_s", "arrived", "origin", "destination",
                             "distance_m", "airborne_s"]
    assert {r["id"] for r in rows} == {"UAM1", "UAM2", "UAM3"}
    uam1 = next(r for r in rows if r["id"] == "UAM1")
    assert uam1["arrived"] == "true" and uam1["destination"] == "WP_EAS"
    with open(out / "trajectories.csv") as fh:
        traj = list(csv.DictReader(fh))
    assert list(traj[0]) == ["id", "simt", "lat", "lon", "alt_m", "tas_mps", "cas_mps", "gs_mps", "trk_deg", "vs_mps"]
    times = sorted({float(r["simt"]) for r in traj})
    assert times[0] == 0.0 and all(t == int(t) for t in times)
    assert (out / "scenario.scn").read_text() == (ROOT / "aamsim/scn/demo.scn").read_text()


def test_run_options_until_log_period_and_determinism(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        proc = aamsim("run", str(ROOT / "aamsim/scn/demo.scn"), "--out", str(out), "--until", "00:02:00",
                      "--log-period", "5", "--quiet", "--dt", "0.1")
        assert proc.returncode == 0 and proc.stdout == ""
    assert (a / "trajectories.csv").read_bytes() == (b / "trajectories.csv").read_bytes()
    summary = json.loads((a / "summary.json").read_text())
    assert summary["sim_time_s"] == 120.0 and summary["dt_s"] == 0.1
    times = {float(r["simt"]) for r in csv.DictReader(open(a / "trajectories.csv"))}
    assert times == {float(t) for t in range(0, 121, 5)}
    proc = aamsim("run", str(ROOT / "aamsim/scn/demo.scn"), "--out", str(tmp_path / "c"), "--until", "30",
                  "--log-period", "0", "--quiet")
    assert proc.returncode == 0 and not (tmp_path / "c" / "trajectories.csv").exists()


def test_bad_lines_are_reported_and_the_run_goes_on(tmp_path):
    scn = tmp_path / "bad.scn"
    scn.write_text("00:00:00.00>CRE A EC35 0 0 90 1000 100\n00:00:01.00>ALT A FLXX\n00:00:02.00>FROB\n"
                   "0:0:3>ECHO reached the end\n")
    proc = aamsim("run", str(scn), "--out", str(tmp_path / "r"), "--until", "10")
    assert proc.returncode == 0
    assert f"{scn}:2: error: ALT: altitude: \"FLXX\"" in proc.stderr
    assert f"{scn}:3: error: unknown command FROB" in proc.stderr
    assert "reached the end" in proc.stderr


def test_strict_lists_all_errors_and_exits_2(tmp_path):
    scn = tmp_path / "bad.scn"
    scn.write_text("00:00:00.00>CRE A EC35 0 0 90 1000 100\n00:00:01.00>ALT A FLXX\n00:00:02.00>FROB\n"
                   "00:00:03.00>HDG NOPE 90\n00:00:04.00>A ATALT 500 SPD A fast\n00:00:05.00>PCALL missing.scn\n"
                   "0:0:6>ADDWPT A UNKNOWNWPT\n")
    proc = aamsim("run", str(scn), "--strict", "--out", str(tmp_path / "r"))
    assert proc.returncode == 2
    for line in (2, 3, 4, 5, 6, 7):
        assert f"{scn}:{line}:" in proc.stderr
    assert "6 error(s)" in proc.stderr
    assert not (tmp_path / "r").exists()
    good = tmp_path / "good.scn"
    good.write_text("00:00:00.00>CRE A EC35 0 0 90 1000 100\n00:00:01.00>A ATALT 500 SPD A 80\n")
    assert aamsim("run", str(good), "--strict", "--until", "5", "--out", str(tmp_path / "g"),
                  "--quiet").returncode == 0


def test_missing_scenario_and_bad_options(tmp_path):
    proc = aamsim("run", "no_such.scn")
    assert proc.returncode == 2 and "scenario not found" in proc.stderr
    assert aamsim("run", "demo", "--nmac", "abc").returncode == 2
    assert aamsim("run", "demo", "--metrics", "safety,bogus").returncode == 2
    proc = aamsim("run", "demo", "--plugin", "NOSUCH", "--out", str(tmp_path / "p"))
    assert proc.returncode == 2 and "unknown plugin NOSUCH" in proc.stderr and "Traceback" not in proc.stderr


def test_commands_listing():
    proc = aamsim("commands")
    assert proc.returncode == 0
    assert "ADDWPT acid, (wpname/lat,lon), [alt, spd, afterwp, beforewp]" in proc.stdout
    assert "CRE acid:txt, actype:txt, pos:latlon, [hdg:hdg], [alt:alt], [spd:spd]" in proc.stdout
    assert "PAN" in proc.stdout


def _run(tmp, name, scn_text, seed):
    scn = tmp / f"{name}.scn"
    if not scn.exists():
        scn.write_text(scn_text)
    out = tmp / f"{name}-{seed}"
    proc = aamsim("run", str(scn), "--out", str(out), "--seed", str(seed), "--quiet", "--log-period", "0")
    assert proc.returncode == 0, proc.stderr
    return out


HEAD_ON = ("00:00:00.00>CRE A EC35 0 0 0 1000 100\n00:00:00.00>CRE B EC35 0.036 0 180 1000 100\n"
           "00:00:00.00>CRE C EC35 0 0.02 0 1000 100\n00:00:00.00>CRE D EC35 0.036 0.02 180 1000 100\n"
           "00:02:00.00>DEL *\n")


def test_compare_risk_ratio_and_refusals(tmp_path):
    base = _run(tmp_path, "enc", HEAD_ON, 1)
    with open(base / "conflicts.csv") as fh:
        events = list(csv.DictReader(fh))
    # Two head-on pairs (A-B, C-D), one NMAC and one LoWC each; tracks 0 and 180 deg at the closest point.
    assert sorted((e["volume"], e["ac1"], e["ac2"]) for e in events) == [
        ("lowc", "A", "B"), ("lowc", "C", "D"), ("nmac", "A", "B"), ("nmac", "C", "D")]
    assert {e["encounter"] for e in events} == {"head-on"}
    assert {(float(e["trk1_deg"]), float(e["trk2_deg"])) for e in events} == {(0.0, 180.0)}
    assert all(float(e["gs1_mps"]) > 50 and float(e["vs2_mps"]) == 0.0 for e in events)
    # "Equipped": the same scenario and seed, where a plugin stops A and B as they are created.
    # From 100 kt (51.4 m/s) at the default 2 m/s^2 each stops within 51.4^2 / 4 = 661 m, so the
    # pair, 4.0 km apart, stays > 2.6 km apart: no event; C-D still meet. Both ratios: 1 / 2.
    (tmp_path / "equip_ab.py").write_text(
        "def init_plugin(sim):\n"
        "    def stop(sim, slot):\n"
        "        if sim.view.ids[slot] in ('A', 'B'):\n"
        "            sim.select_speed(slot, 0.0)\n"
        "    sim.hooks.created.add(stop, name='equip_ab')\n")
    eq = tmp_path / "eq"
    proc = aamsim("run", str(tmp_path / "enc.scn"), "--out", str(eq), "--seed", "1", "--quiet", "--log-period", "0",
                  "--plugin", "equip_ab", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    proc = aamsim("compare", str(eq), str(base))
    assert proc.returncode == 0 and "risk ratio (NMAC): 0.5000" in proc.stdout, proc.stdout
    # The cost beside the ratios: both runs complete nothing (DEL * at 2 min), the same on both sides: no warning.
    assert "flights completed" in proc.stdout and "warning" not in proc.stderr, proc.stdout + proc.stderr
    comparison = json.loads((eq / "comparison.json").read_text())
    assert comparison["risk_ratio"]["mean"] == 0.5 and comparison["lowc_ratio"]["mean"] == 0.5
    other_seed = _run(tmp_path, "enc", HEAD_ON, 2)
    proc = aamsim("compare", str(other_seed), str(base))
    assert proc.returncode == 2 and "seed" in proc.stderr
    other_scn = _run(tmp_path, "other", HEAD_ON.replace("0.02", "0.03"), 1)
    proc = aamsim("compare", str(other_scn), str(base))
    assert proc.returncode == 2 and "different scenarios" in proc.stderr


def test_compare_many_runs_mean_and_std(tmp_path):
    from aamsim.metrics.compare import RunMetrics, compare_runs

    def rm(seed, nmac, lowc, tag):
        return RunMetrics(f"{tag}{seed}", "s", "h", seed, nmac, lowc, {})
    runs = [rm(1, 1, 5, "r"), rm(2, 0, 4, "r"), rm(3, 2, 6, "r")]
    base = [rm(1, 4, 10, "b"), rm(2, 2, 8, "b"), rm(3, 4, 12, "b")]
    cmp = compare_runs(runs, base)
    assert cmp.risk_ratio.mean == pytest.approx((0.25 + 0.0 + 0.5) / 3)
    assert cmp.risk_ratio.std == pytest.approx(0.2041241, rel=1e-6)
    assert cmp.risk_ratio.pooled == pytest.approx(3 / 10)
    assert cmp.lowc_ratio.mean == pytest.approx(0.5)


def test_compare_shows_the_operational_cost_and_warns_when_completions_differ(tmp_path):
    from aamsim.metrics.compare import RunMetrics, compare_runs, format_operational

    def rm(seed, done, holding, tag):
        op = {"flights_scheduled": 100, "flights_completed": done, "flights_unfinished": 100 - done,
              "flights_not_departed": 0, "airborne_holding_s": holding, "mean_delay_s": 10.0 * seed,
              "advisories": 7 if tag == "r" else 0}
        return RunMetrics(f"{tag}{seed}", "s", "h", seed, 1, 2, op)
    same = compare_runs([rm(1, 100, 30.0, "r"), rm(2, 100, 60.0, "r")], [rm(1, 100, 0.0, "b"), rm(2, 100, 0.0, "b")])
    assert same.warnings == []
    assert same.operational["run"] == {"flights_scheduled": 100, "flights_completed": 100, "flights_unfinished": 0,
                                       "flights_not_departed": 0, "airborne_holding_s": 45.0, "mean_delay_s": 15.0,
                                       "advisories": 7}
    assert same.operational["baseline"]["airborne_holding_s"] == 0.0
    lines = format_operational(same)
    assert lines[0].startswith("operational cost (mean per run)")
    assert lines[2].split() == ["flights", "completed", "100", "100"]
    assert lines[5].split() == ["airborne", "holding", "[s]", "45", "0"]
    # Seed 2's run left 8 flights unfinished: named, with both counts.
    differ = compare_runs([rm(1, 100, 0.0, "r"), rm(2, 92, 0.0, "r")], [rm(1, 100, 0.0, "b"), rm(2, 100, 0.0, "b")])
    assert len(differ.warnings) == 1 and "seed 2: 92 against 100" in differ.warnings[0]
    assert "seed 1" not in differ.warnings[0]
    assert differ.operational["run"]["flights_completed"] == 96.0
    assert differ.per_seed[1]["flights_completed"] == 92 and differ.per_seed[1]["baseline_flights_completed"] == 100
    # A summary without the figures (an older run) leaves them out instead of inventing them.
    bare = compare_runs([RunMetrics("r", "s", "h", 1, 1, 2, {})], [RunMetrics("b", "s", "h", 1, 2, 2, {})])
    assert bare.operational["run"]["flights_completed"] is None and bare.warnings == []
    assert format_operational(bare) == [format_operational(bare)[0]]


def test_progress_speed_up_is_blank_for_the_first_interval_then_per_interval() -> None:
    from aamsim.cli import _Progress

    progress = _Progress(None, quiet=True)
    # The first interval holds the start-up: 10 sim s in 40 wall s would read "0x".
    assert progress.speedup_text(10.0, 40.0) == ""
    assert progress.speedup_text(1010.0, 41.0) == "1000x"  # 1,000 sim s in the next wall second
    assert progress.speedup_text(1010.0, 41.0) == ""  # no wall time passed: nothing to divide


def test_a_finished_run_leaves_fast_but_runs_exit_handlers_and_flushes(tmp_path):
    """``aamsim run`` skips the interpreter's teardown (aamsim/entry.py), not what an exit must do:
    plugins' atexit functions run, buffered output reaches the pipe, the exit status is the run's. The
    imports' objects are frozen out of the garbage collector's sight; garbage made in the run is collected."""
    (tmp_path / "exit_plugin.py").write_text(
        "import atexit, gc, sys, weakref\n"
        "class Node: pass\n"
        "def init_plugin(sim):\n"
        "    sys.stdout.write('buffered line from the plugin\\n')\n"  # sits in the pipe's buffer until the flush
        "    cycle = Node(); cycle.me = cycle; alive = weakref.ref(cycle); del cycle\n"  # only a collection frees it
        "    def at_exit():\n"
        "        gc.collect()\n"
        f"        report = open({str(tmp_path / 'atexit.txt')!r}, 'w')\n"
        "        report.write(f'ran {gc.get_freeze_count()} {alive() is None}')\n"
        "    atexit.register(at_exit)\n"
    )
    scn = tmp_path / "one.scn"
    scn.write_text("00:00:00.00>CRE A1 EC35 40.7 -74.0 90 1500 100\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), str(tmp_path)]))
    proc = subprocess.run([sys.executable, "-m", "aamsim", "run", str(scn), "--until", "5", "--out",
                           str(tmp_path / "run"), "--plugin", "exit_plugin", "--quiet"],
                          check=False, capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "buffered line from the plugin\n"
    ran, frozen, collected = (tmp_path / "atexit.txt").read_text().split()
    assert ran == "ran" and int(frozen) > 10_000 and collected == "True"
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["sim_time_s"] == 5.0
    assert len((tmp_path / "run" / "trajectories.csv").read_text().splitlines()) == 1 + 6  # header, t = 0..5
    bad = subprocess.run([sys.executable, "-m", "aamsim", "run", str(tmp_path / "missing.scn"), "--quiet"],
                         check=False, capture_output=True, text=True, env=env, timeout=600)
    assert bad.returncode == 2 and "scenario not found" in bad.stderr


def test_a_scenario_that_is_neither_a_file_nor_shipped_names_the_shipped_ones(tmp_path):
    proc = aamsim("run", "my_scenario.scn", cwd=tmp_path)
    assert proc.returncode == 2
    assert ("scenario not found: my_scenario.scn (neither a file nor a shipped scenario; shipped: demo, "
            "merge_conflict, nyc_day, nyc_eval_678, nyc_train_100)") in proc.stderr, proc.stderr
