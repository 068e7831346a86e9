"""Replaying recorded real traffic in a simulation (REPLAY, aamsim run --overlay): hand-computed
interpolation, gaps and landings, time alignment, refusal of intents, events split AAM vs real."""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from aamsim import Simulation
from aamsim.errors import CommandError
from aamsim.realtraffic.replay import RecordingFeed, Replay, replays_of
from aamsim.realtraffic.tracks import build_tracks
from aamsim.realtraffic.readers import read_reports
from aamsim.units import FT

ROOT = Path(__file__).resolve().parents[1]
REGA = ROOT / "tests" / "data" / "opensky" / "rega_zh.json.gz"
HEADER = "time,icao24,lat,lon,velocity,heading,vertrate,callsign,onground,baroaltitude\n"


def write_recording(path: Path, rows: list[str]) -> Path:
    path.write_text(HEADER + "".join(r + "\n" for r in rows))
    return path


@pytest.fixture
def recording(tmp_path: Path) -> Path:
    """Aircraft aaa001: 1000 s (47.00, 8.00, 500 m), 1010 s (47.01, 8.00, 600 m), 1020 s (47.01, 8.02, 600 m),
    then a 90 s gap and 1110 s / 1120 s. Aircraft aaa002: airborne 1000/1010, on the ground at 1015,
    airborne again 1020/1030. A row with a broken latitude (line 12)."""
    return write_recording(tmp_path / "rec.csv", [
        "1000,aaa001,47.00,8.00,111.2,0,10,TEST1,false,500",
        "1000,aaa002,46.50,7.50,50,90,0,TEST2,false,300",
        "1010,aaa001,47.01,8.00,111.2,0,10,TEST1,false,600",
        "1010,aaa002,46.50,7.51,50,90,0,TEST2,false,300",
        "1015,aaa002,46.50,7.515,0,90,0,TEST2,true,300",
        "1020,aaa001,47.01,8.02,151.7,90,0,TEST1,false,600",
        "1020,aaa002,46.50,7.52,50,90,0,TEST2,false,300",
        "1030,aaa002,46.50,7.53,50,90,0,TEST2,false,300",
        "1110,aaa001,47.02,8.02,0,0,0,TEST1,false,700",
        "1120,aaa001,47.03,8.02,0,0,0,TEST1,false,800",
        "1125,aaa003,north,8.0,0,0,0,BAD,false,100",
    ])


def simulation(dt: float = 0.5) -> Simulation:
    sim = Simulation(dt=dt)
    sim.services.start()
    return sim


def state(sim: Simulation, acid: str) -> tuple[float, float, float]:
    i = sim.view.slot(acid)
    return float(sim.view.lat[i]), float(sim.view.lon[i]), float(sim.view.alt[i])


def test_position_between_reports_is_the_linear_interpolation(recording):
    sim = simulation(dt=0.5)
    assert sim.stack(f"REPLAY {recording}")
    sim.run_until(2.5)  # recording 1002.5: a quarter of the way from the 1000 s to the 1010 s report
    lat, lon, alt = state(sim, "RTAAA001")
    assert lat == pytest.approx(47.0025, abs=1e-9)
    assert lon == pytest.approx(8.0, abs=1e-9)
    assert alt == pytest.approx(525.0, abs=1e-6)
    sim.run_until(15.0)  # 1015: halfway between (47.01, 8.00) and (47.01, 8.02)
    lat, lon, alt = state(sim, "RTAAA001")
    assert (lat, lon, alt) == (pytest.approx(47.01, abs=1e-9), pytest.approx(8.01, abs=1e-9),
                               pytest.approx(600.0, abs=1e-6))
    # Between updates the kernel's step carries it at the chord velocity: 0.02 deg of longitude in
    # 10 s at 47.01 N is 111.195 km/deg * cos(47.01) * 0.02 / 10 = 151.64 m/s east.
    i = sim.view.slot("RTAAA001")
    assert sim.view.gseast[i] == pytest.approx(math.radians(0.02) * 6371000.0 * math.cos(math.radians(47.01)) / 10,
                                               rel=1e-9)
    assert sim.view.trk[i] == pytest.approx(90.0)
    assert sim.view.noncooperative[i]


def test_gap_splits_track_and_landing_ends_it(recording):
    sim = simulation(dt=0.5)
    sim.stack(f"REPLAY {recording}")
    sim.run_until(8.0)
    assert "RTAAA002" in sim.view  # 1000..1010 airborne
    sim.run_until(16.0)
    assert "RTAAA002" not in sim.view  # the report at 1015 is on the ground: that stretch ended at 1010
    assert "RTAAA001" in sim.view
    sim.run_until(25.0)
    assert "RTAAA002-2" in sim.view  # airborne again from 1020
    assert "RTAAA001" not in sim.view  # last report of the first stretch at 1020; next one 90 s later
    sim.run_until(112.0)
    assert "RTAAA001-2" in sim.view and state(sim, "RTAAA001-2")[2] == pytest.approx(720.0, abs=1e-6)
    replay = replays_of(sim)[0]
    assert [(f.callsign, f.recorded_callsign) for f in replay.flights] == [
        ("RTAAA001", "TEST1"), ("RTAAA002", "TEST2"), ("RTAAA002-2", "TEST2"), ("RTAAA001-2", "TEST1")]
    # The broken row was reported with its file and line (the header is line 1), and skipped.
    warnings = [str(m) for m in sim.reporter.messages if m.kind == "warning"]
    assert any(f"{recording}:12: bad latitude or longitude" in w for w in warnings), warnings


def test_offset_and_utc_alignment(recording):
    sim = simulation(dt=0.5)
    sim.stack(f"REPLAY {recording} 00:01:40")  # the first report (1000 s) at scenario time 100 s
    sim.run_until(50.0)
    assert sim.view.n == 0
    sim.run_until(102.5)
    assert state(sim, "RTAAA001")[0] == pytest.approx(47.0025, abs=1e-9)
    sim2 = simulation(dt=0.5)
    sim2.stack(f"REPLAY {recording} @1970-01-01T00:16:45Z")  # recording time 1005 s at scenario time 0
    sim2.run_until(0.0)
    assert state(sim2, "RTAAA001")[0] == pytest.approx(47.005, abs=1e-9)
    sim3 = simulation(dt=0.5)
    sim3.stack(f"REPLAY {recording} -5")  # 5 s into the recording at time 0
    sim3.run_until(0.0)
    assert state(sim3, "RTAAA001")[0] == pytest.approx(47.005, abs=1e-9)


def test_area_keeps_only_reports_inside(recording):
    sim = simulation()
    sim.stack(f"REPLAY {recording},,46.9,7.9,47.1,8.1")
    sim.run_until(5.0)
    assert sim.view.ids == ("RTAAA001",)


def test_replayed_aircraft_refuse_intents_and_del_removes_them(recording):
    sim = simulation()
    sim.stack(f"REPLAY {recording}")
    sim.run_until(2.0)
    assert not sim.stack("SPD RTAAA001 100")
    message = str(sim.reporter.messages[-1])
    assert "RTAAA001: real traffic replayed from a recording (non-cooperative)" in message
    for intent in (lambda: sim.select_speed("RTAAA001", 50.0), lambda: sim.select_altitude("RTAAA001", 300.0),
                   lambda: sim.select_heading("RTAAA001", 10.0), lambda: sim.hold_speed(["RTAAA001"]),
                   lambda: sim.edit_route(sim.slot("RTAAA001"))):
        with pytest.raises(CommandError, match="takes no advisories or intents"):
            intent()
    sim.stack("CRE UAM1 EC35 47 8 0 1000 0")
    with pytest.raises(CommandError):
        sim.select_speed(["UAM1", "RTAAA001"], 20.0)  # one refused: none is changed
    with pytest.raises(CommandError, match="only replayed"):
        sim.set_replay_state("UAM1", *(np.zeros(1) for _ in range(6)))
    sim.stack("DEL RTAAA001")
    sim.run_until(10.0)
    assert "RTAAA001" not in sim.view and "UAM1" in sim.view
    assert replays_of(sim)[0].flights[0].removed_by_user


def test_replay_flights_are_not_aam_flights(recording):
    sim = simulation()
    sim.stack(f"REPLAY {recording}")
    sim.stack("CRE UAM1 EC35 47 8 0 1000 0")
    sim.run_until(20.0)
    assert [r.acid for r in sim.flights()] == ["UAM1"]
    assert {r.acid for r in sim.flights(real_traffic=True)} == {"RTAAA001", "RTAAA002", "RTAAA002-2"}


def test_streamed_window_gives_the_same_states_as_the_whole_file(tmp_path):
    """A recording streamed in blocks of 7 reports, keeping a window, flies as the whole file read at once."""
    rng = np.random.default_rng(5)
    rows = []
    for t in range(0, 1200, 5):
        for k in range(6):
            if k == 3 and 400 <= t < 520:
                continue  # a two-minute gap: that aircraft's track splits
            lat = 47.0 + 0.01 * k + 1e-4 * t + 1e-6 * rng.normal()
            rows.append(f"{10000 + t},bbb00{k},{lat:.7f},{8.0 + 2e-4 * t:.7f},50,45,0,S{k},false,{400 + t / 10:.2f}")
    path = write_recording(tmp_path / "stream.csv", rows)
    whole = RecordingFeed(path)
    streamed = RecordingFeed(path, stream_above_bytes=0, chunk_rows=7)
    assert not whole.streaming and streamed.streaming
    assert whole.start() == streamed.start() == 10000.0
    for t in np.arange(10000.0, 11200.0, 37.3):
        a, b = whole.tracks_at(t).states_at(t), streamed.tracks_at(t).states_at(t)
        assert len(a) == len(b)
        np.testing.assert_allclose(np.sort(a.lat), np.sort(b.lat), rtol=0, atol=1e-12)
        assert streamed.reports_kept <= 6 * (60 + 2 * 300 + 40) // 5 + 7  # the window, not the file (1,416 rows)
    assert streamed.eof and streamed.late_reports == 0 and streamed.builds == 3  # at 0, 300+ and 600+ s
    assert streamed.finished(11200.0) and not streamed.finished(11000.0)


def test_streamed_recording_out_of_time_order_counts_late_reports(tmp_path):
    rows = [f"{10000 + t},ccc001,47.0,{8 + t * 1e-5:.6f},50,90,0,X,false,500" for t in range(0, 3000, 10)]
    # Written after the reports of 12,500 s: read when the replay is long past 10,005 s.
    rows.insert(251, "10005,ccc002,47.1,8.0,50,90,0,Y,false,500")
    path = write_recording(tmp_path / "late.csv", rows)
    feed = RecordingFeed(path, stream_above_bytes=0, chunk_rows=10)
    feed.start()
    for t in range(10000, 13000, 100):
        assert len(feed.tracks_at(float(t)).states_at(float(t))) == 1
    assert feed.late_reports == 1 and feed.first_late_s == 10005.0


def test_rega_replay_matches_tracks_states_at():
    """The genuine REGA recording: the replayed helicopter is where TrackSet.states_at says, at every update."""
    tracks = build_tracks(read_reports(REGA))
    t0 = tracks.time_span[0]
    sim = simulation(dt=0.05)
    sim.stack(f"REPLAY {REGA}")
    for t in (0.0, 1.0, 60.0, 61.0, 200.0, 337.0):
        sim.run_until(t)
        expected = tracks.states_at(t0 + t)
        lat, lon, alt = state(sim, "RT4B43AC")
        assert (lat, lon, alt) == (pytest.approx(expected.lat[0], abs=1e-9), pytest.approx(expected.lon[0], abs=1e-9),
                                   pytest.approx(expected.alt_m[0], abs=1e-6))
    sim.run_until(340.0)
    assert sim.view.n == 0  # the last report is 338 s after the first


def test_update_interval_never_below_the_step(recording):
    replay = Replay(RecordingFeed(recording), name="x", interval_s=1.0)
    sim = simulation(dt=2.0)
    replay.attach(sim)
    sim.run_until(4.0)
    assert state(sim, "RTAAA001")[0] == pytest.approx(47.004, abs=1e-9)


def aamsim(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "aamsim", *args], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=600)


def test_run_overlay_end_to_end(tmp_path):
    """aamsim run --overlay: a hovering AAM aircraft on the helicopter's track at +60.5 s, and two AAM aircraft
    1 m apart: one AAM-vs-real and one AAM-vs-AAM NMAC, reported apart."""
    scn = tmp_path / "enc.scn"
    scn.write_text("00:00:00.00>CRE UAM1 EC35 47.36308 8.53412 0 2575 0\n"
                   "00:00:00.00>CRE UAM2 EC35 47.5 8.7 0 1500 0\n"
                   "00:00:00.00>CRE UAM3 EC35 47.5 8.70001 0 1500 0\n"
                   "00:00:10.00>ALT RT4B43AC 3000\n")
    out = tmp_path / "out"
    proc = aamsim("run", str(scn), "--until", "400", "--out", str(out), "--overlay", str(REGA))
    assert proc.returncode == 0, proc.stderr
    assert "AAM vs AAM: 1 NMAC" in proc.stdout and "AAM vs real traffic: 1 NMAC" in proc.stdout
    assert "ALT: RT4B43AC: real traffic replayed from a recording" in proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    safety = summary["safety"]
    assert (safety["nmac_events"], safety["nmac_events_aam_vs_aam"], safety["nmac_events_aam_vs_real_traffic"]) \
        == (2, 1, 1)
    assert summary["flights_created"] == 3  # the AAM flights; the helicopter is in real_traffic.csv
    assert summary["real_traffic"][0]["aircraft_replayed"] == 1
    with open(out / "conflicts.csv") as fh:
        rows = [r for r in csv.DictReader(fh) if r["volume"] == "nmac"]
    real = next(r for r in rows if r["pair"] == "AAM vs real traffic")
    assert (real["ac1"], real["ac2"]) == ("RT4B43AC", "UAM1")
    # The closest point: the helicopter passes within a metre at +60.5 s (2575 ft = 784.86 m).
    assert float(real["min_dist_m"]) < 1.0 and float(real["t_min_s"]) == pytest.approx(60.5, abs=0.5)
    assert next(r for r in rows if r["pair"] == "AAM vs AAM")["ac1"] == "UAM2"
    with open(out / "real_traffic.csv") as fh:
        replayed = list(csv.DictReader(fh))
    assert [(r["id"], r["icao24"], r["callsign"], r["deleted_s"]) for r in replayed] == [
        ("RT4B43AC", "4b43ac", "REGA1", "339.00")]
    assert 2575 * FT == pytest.approx(784.86)


def test_run_overlay_missing_file_is_a_clear_error(tmp_path):
    scn = tmp_path / "a.scn"
    scn.write_text("00:00:00.00>CRE UAM1 EC35 47 8 0 1000 0\n")
    proc = aamsim("run", str(scn), "--until", "10", "--out", str(tmp_path / "o"), "--overlay", "nowhere.csv")
    assert proc.returncode == 2
    assert "--overlay: REPLAY: recording not found: nowhere.csv" in proc.stderr


def test_real_vs_real_events_are_listed_but_not_aam_events(tmp_path):
    path = write_recording(tmp_path / "two.csv", [
        "0,ddd001,47.0,8.0,10,0,0,A,false,500", "0,ddd002,47.0,8.00001,10,0,0,B,false,500",
        "50,ddd001,47.001,8.0,10,0,0,A,false,500", "50,ddd002,47.001,8.00001,10,0,0,B,false,500"])
    sim = simulation()
    sim.stack(f"REPLAY {path}")
    sim.stack("CRE UAM1 EC35 48 8 0 1000 0")
    sim.run_until(50.0)

    safety = sim.services.start().metrics.compute(sim, ("safety",))["safety"]
    assert safety["nmac_events"] == 0 and safety["nmac_events_aam_vs_real_traffic"] == 0

    assert sim.services.start().conflicts.count("nmac") == 1  # seen by conflict detection, not an AAM event


def test_two_runs_are_identical(recording):
    def run() -> tuple:
        sim = simulation(dt=0.5)
        sim.stack(f"REPLAY {recording}")
        sim.stack("CRE UAM1 EC35 47.005 8.0 0 1640 0")
        sim.run_until(30.0)
        return tuple(sim.view.ids), sim.view.lat.tobytes(), sim.view.alt.tobytes()

    assert run() == run()
