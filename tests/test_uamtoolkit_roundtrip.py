"""End to end: schedule -> uam2scn -> aamsim run -> flights.csv; the shipped scenarios; the figure."""

from __future__ import annotations

import csv
import io
import itertools
import re
from pathlib import Path

import numpy as np
import pytest
from uam_helpers import created_callsigns, read_flights, run_module

from aamsim import Simulation
from aamsim.scenarios import packaged_scenario
from uamtoolkit_import.convert import ConvertOptions, convert, scenario_names
from uamtoolkit_import.netfile import nyc_network
from uamtoolkit_import.scenarios import SHIPPED, regenerate
from uamtoolkit_import.schedule import Schedule, ScheduledFlight, parse_schedule, read_schedule

NET = nyc_network()
NAMES = scenario_names(NET)


def test_synth_schedule_to_scn_to_aamsim_flights(tmp_path: Path):
    sched_path, scn, run_dir = tmp_path / "s.csv", tmp_path / "s.scn", tmp_path / "run"
    r = run_module("uamtoolkit_import", "synth", "--fleet", "30", "--seed", "3", "-o", str(sched_path))
    assert r.returncode == 0, r.stderr
    r = run_module(
        "uamtoolkit_import", str(sched_path), "-o", str(scn), "--start", "08:00", "--end", "08:20", "--seed", "9"
    )
    assert r.returncode == 0, r.stderr
    written = created_callsigns(scn.read_text())
    assert re.search(rf": {len(written)} flights written, 0 skipped, \d+ outside the time window", r.stdout)
    assert len(written) >= 10
    r = run_module("aamsim", "run", str(scn), "--out", str(run_dir), "--quiet")
    assert r.returncode == 0, r.stderr
    flights = read_flights(run_dir)
    schedule = {f.callsign: f for f in read_schedule(sched_path, NET).flights}
    assert set(flights) == set(written)  # every written flight is created, nothing else
    for cs in written:
        row, sched = flights[cs], schedule[cs]
        assert row["arrived"] == "true", row
        assert row["destination"] == NAMES[sched.destination] and row["origin"] == NAMES[sched.origin]
        assert float(row["created_s"]) == pytest.approx(sched.departure_s - 8 * 3600, abs=0.01)


def test_hand_written_csv_with_aliases_runs(tmp_path: Path):
    text = (
        "Flight No,Vehicle,From,To,STD,STA,Path,Speed [m/s],Lane (m)\n"
        "ab-1,V7,JFK,DMH,06:00,06:12,JFK;VW03;VW02;VW01;LIE02;LIE01;ER05;ER04;ER03;ER02;DMH,70,152.4\n"
        "ab-2,V8,TEB,EWR,06:01,,,60,365.76\n"
    )
    sched = parse_schedule(io.StringIO(text), NET, "hand.csv")
    assert sched.errors == []
    sim = Simulation(use_bluesky_navdata=False)
    assert sim.load_text(convert(sched, NET, ConvertOptions(start_s=6 * 3600)).text).errors == []
    sim.run()
    recs = {r.acid: r for r in sim.flight_log}
    assert set(recs) == {"AB1", "AB2"} and all(r.arrived for r in recs.values())
    assert recs["AB1"].destination == NAMES["DMH"] and recs["AB2"].destination == NAMES["EWR"]
    assert recs["AB1"].scheduled_arrival_s == pytest.approx(720.0)


def test_shipped_scenarios_are_what_the_documented_command_writes(tmp_path: Path):
    written = {p.name: (n, start) for p, n, start in regenerate(tmp_path)}
    for spec in SHIPPED:
        shipped = packaged_scenario(spec.filename)
        assert shipped is not None, f"{spec.filename} is not shipped"
        assert (tmp_path / spec.filename).read_text() == shipped.read_text(), (
            f"{spec.filename} is stale: run `uam2scn scenarios`"
        )
        text = shipped.read_text()
        cre_times = [line.split(">")[0] for line in text.splitlines() if ">CRE " in line]
        if spec.flights is not None:
            assert written[spec.filename][0] == spec.flights == len(cre_times)
            assert max(cre_times) < f"{int(spec.length_s // 3600):02d}:{int(spec.length_s % 3600 // 60):02d}:00.00"
            assert min(cre_times) >= "00:00:00.00"
        else:
            assert written[spec.filename][1] == 0.0 and len(cre_times) > 3000
        assert set(re.findall(r"^\d\d:\d\d:\d\d\.\d\d>CRE \w+ (\w+) ", text, flags=re.MULTILINE)) == {"EC35"}


def test_training_scenario_all_arrive_and_has_close_encounters(tmp_path: Path):
    run_dir = tmp_path / "run"
    r = run_module("aamsim", "run", "scn/nyc_train_100.scn", "--out", str(run_dir), "--quiet")
    assert r.returncode == 0, r.stderr
    flights = read_flights(run_dir)
    assert len(flights) == 100 and all(f["arrived"] == "true" for f in flights.values())
    # The unequipped baseline must have NMAC-like encounters (pairs closer than 150 m in 3-D).
    assert close_pairs(run_dir / "trajectories.csv", 150.0) > 0


def close_pairs(path: Path, threshold_m: float) -> int:
    by_time: dict[str, list[tuple[str, float, float, float]]] = {}
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            by_time.setdefault(row["simt"], []).append(
                (row["id"], float(row["lat"]), float(row["lon"]), float(row["alt_m"]))
            )
    pairs: set[tuple[str, str]] = set()
    for rows in by_time.values():
        if len(rows) < 2:
            continue
        ids = [r[0] for r in rows]
        lat, lon, alt = (np.array([r[k] for r in rows]) for k in (1, 2, 3))
        y = np.radians(lat) * 6371000.0
        x = np.radians(lon) * 6371000.0 * np.cos(np.radians(lat.mean()))
        d = np.sqrt((x[:, None] - x) ** 2 + (y[:, None] - y) ** 2 + (alt[:, None] - alt) ** 2)
        pairs.update((ids[i], ids[j]) for i, j in zip(*np.nonzero(np.triu(d < threshold_m, 1))))
    return len(pairs)


def test_figure_draws_a_png(tmp_path: Path):
    from click.testing import CliRunner

    from aamsim.runner import RunConfig, run_scenario
    from uamtoolkit_import.cli import main

    scn = tmp_path / "one.scn"
    rows = [
        ScheduledFlight(
            2,
            "F1",
            "F1",
            "",
            "",
            "DMH",
            "JFK",
            0.0,
            float("nan"),
            tuple(NET.shortest_path("DMH", "JFK")[1:-1]),
            140.0,
            500.0,
        )
    ]
    scn.write_text(convert(Schedule("x", rows, [], 1), NET).text)
    run_dir = run_scenario(RunConfig(scn, tmp_path / "run")).out_dir
    out = tmp_path / "traffic.png"
    result = CliRunner().invoke(main, ["figure", str(run_dir), "-o", str(out), "--snapshot", "120"])
    assert result.exit_code == 0, result.output
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 20_000
    assert "1 trajectories" in result.output


def test_every_od_pair_of_the_new_york_network_arrives_at_full_speed(tmp_path: Path):
    """Fly-by turns at 150 kt must not make any aircraft miss its vertiport (it would fly on forever)."""
    rows = []
    for k, (o, d) in enumerate(itertools.permutations(NET.vertiports, 2), start=1):
        path = NET.shortest_path(o, d)
        rows.append(
            ScheduledFlight(
                k + 1, f"P{k:04d}", f"P{k:04d}", "", "", o, d, 0.0, float("nan"), tuple(path[1:-1]), 150.0, 500.0
            )
        )
    sim = Simulation(use_bluesky_navdata=False)
    sim.load_text(convert(Schedule("pairs", rows, [], len(rows)), NET, ConvertOptions(alt_noise_ft=0.0)).text)
    sim.run(until_s=3600.0)
    missed = [(r.origin, r.destination) for r in sim.flight_log if not r.arrived]
    assert sim.view.n == 0 and not missed and len(sim.flight_log) == len(rows)
