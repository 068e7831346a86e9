"""Frames and map layouts of the viewer: a hand-written run directory and a live simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aamsim import Simulation
from aamsim.metrics import record_advisory
from aamsim.viewer.frames import (
    STATUS_HOLDING,
    STATUS_LOWC,
    STATUS_NMAC,
    STATUS_NORMAL,
    ReplayError,
    RunReplay,
    frame_from_sim,
    layout_from_scenario,
)

SCENARIO = """\
# two vertiports and one route through a node
00:00:00.00>DEFWPT VA 40.00 -74.00
00:00:00.00>DEFWPT VB 40.10 -74.00
00:00:00.00>DEFWPT N1 40.05 -74.01
00:00:00.00>CRE A1 EC35 40.00 -74.00 0 500 0
00:00:00.00>ORIG A1 VA
00:00:00.00>DEST A1 VB
00:00:00.00>ADDWPT A1 N1
00:00:05.00>CRE A2 EC35 40.10 -74.00 180 500 0
00:00:05.00>ORIG A2 VB
00:00:05.00>DEST A2 VA
00:00:05.00>ADDWPT A2 N1
"""

TRAJ_HEADER = "id,simt,lat,lon,alt_m,tas_mps,cas_mps,gs_mps,trk_deg,vs_mps\n"


@pytest.fixture()
def run_dir(tmp_path):
    rows = [
        # A1 flies north at 100 m/s; A2 is created at 10 s and hovers (tas 1 m/s: holding) until 12 s
        "A1,10.00,40.0000000,-74.0000000,150.0,100.0,99.0,100.0,0.0000,0.0",
        "A2,10.00,40.0100000,-74.0000000,150.0,1.0,1.0,1.0,180.0000,0.0",
        "A1,11.00,40.0008993,-74.0000000,150.0,100.0,99.0,100.0,0.0000,0.0",
        "A2,11.00,40.0099910,-74.0000000,150.0,1.0,1.0,1.0,180.0000,0.0",
        "A1,12.00,40.0017987,-74.0000000,150.0,100.0,99.0,100.0,0.0000,0.0",
    ]
    (tmp_path / "trajectories.csv").write_text(TRAJ_HEADER + "\n".join(rows) + "\n")
    (tmp_path / "conflicts.csv").write_text(
        "volume,ac1,ac2,start_s,end_s,min_dist_m,t_min_s,lat1,lon1,alt1_m,lat2,lon2,alt2_m\n"
        "lowc,A1,A2,10.50,11.50,420.0,11.0,40.0,-74.0,150.0,40.01,-74.0,150.0\n"
        "nmac,A1,A2,11.20,11.40,140.0,11.3,40.0,-74.0,150.0,40.002,-74.002,150.0\n")
    (tmp_path / "flights.csv").write_text(
        "id,type,created_s,deleted_s,arrived,origin,destination,distance_m,airborne_s\n"
        "A2,EC35,10.00,11.50,true,VB,VA,100.0,1.5\n"
        "A1,EC35,0.00,,false,VA,VB,1200.0,12.0\n")
    (tmp_path / "summary.json").write_text('{"scenario": "tiny", "operational": {"holding_speed_threshold_mps": 2.0}}')
    (tmp_path / "scenario.scn").write_text(SCENARIO)
    return tmp_path


def test_a_frame_at_a_sample_time_holds_the_samples_and_their_states(run_dir):
    r = RunReplay(run_dir)
    assert (r.t_start, r.t_end, r.sample_period_s) == (10.0, 12.0, 1.0)
    f = r.frame_at(10.0)
    assert f.ids == ("A1", "A2")
    np.testing.assert_array_equal(f.lat, [40.0, 40.01])
    # A2 at 1 m/s is under the run's 2 m/s holding threshold; no event has begun at 10 s
    assert f.status.tolist() == [STATUS_NORMAL, STATUS_HOLDING]
    assert f.metrics == {"airborne": 2, "nmac": 0, "lowc": 0, "completed": 0, "holding": 1}


def test_between_samples_the_frame_is_dead_reckoned_and_states_follow_the_events(run_dir):
    r = RunReplay(run_dir)
    f = r.frame_at(11.3, events_since=11.0)
    # 0.3 s at 100 m/s due north: 30 m = 30 / 6371000 rad of latitude
    assert f.lat[0] == pytest.approx(40.0008993 + math.degrees(30.0 / 6_371_000.0), abs=1e-9)
    assert f.lon[0] == pytest.approx(-74.0, abs=1e-12)
    assert f.status.tolist() == [STATUS_NMAC, STATUS_NMAC]  # NMAC (11.2-11.4) wins over LoWC (10.5-11.5)
    assert [(e.kind, e.t, e.ids) for e in f.events] == [("nmac", 11.2, ("A1", "A2"))]
    assert (f.events[0].lat, f.events[0].lon) == pytest.approx((40.001, -74.001))
    assert (f.metrics["nmac"], f.metrics["lowc"]) == (1, 1)
    later = r.frame_at(11.45)
    assert later.status.tolist() == [STATUS_LOWC, STATUS_LOWC]
    end = r.frame_at(12.0)
    assert end.ids == ("A1",) and end.status.tolist() == [STATUS_NORMAL]
    assert end.metrics["completed"] == 1  # A2 arrived at 11.5 s
    # past the last sample the last picture holds
    np.testing.assert_array_equal(r.frame_at(99.0).lat, end.lat)


def test_trails_hold_each_aircraft_samples_oldest_first(run_dir):
    trails = RunReplay(run_dir).trails(12.0, 1.5)
    assert sorted(trails) == ["A1", "A2"]
    np.testing.assert_allclose(trails["A1"][:, 0], [40.0008993, 40.0017987])
    assert trails["A2"].shape == (1, 2)


def test_the_map_comes_from_the_scenario_network(run_dir):
    layout = RunReplay(run_dir).layout()
    assert [v[0] for v in layout.vertiports] == ["VA", "VB"]  # N1 is a route node, not an end
    # legs VA-N1 and N1-VB, each drawn once although two flights use them
    legs = sorted(tuple(map(tuple, r.round(3).tolist())) for r in layout.routes)
    assert legs == [((40.0, -74.0), (40.05, -74.01)), ((40.05, -74.01), (40.1, -74.0))]
    lat0, lat1, lon0, lon1 = layout.bounds
    assert lat0 < 40.0 and lat1 > 40.1 and lon0 < -74.01 and lon1 > -74.0


def test_a_layout_reads_commas_and_lat_lon_waypoints():
    layout = layout_from_scenario("0:00:00>CRE X,EC35,52.0,4.0,0,500,0\nADDWPT X 52.1 4.1\nADDWPT X,52.2,4.0\n")
    assert layout.vertiports == ()
    assert len(layout.routes) == 2


@pytest.mark.parametrize("name, content, expected", [
    ("trajectories.csv", None, "trajectories.csv: missing"),
    ("trajectories.csv", "id,simt,lat\nA,1,2\n", "line 1: missing column(s) lon, alt_m"),
    ("trajectories.csv", TRAJ_HEADER + "A,abc,40,-74,1,1,1,1,0,0\n", "trajectories.csv"),
    ("summary.json", "{not json", "summary.json: not valid JSON"),
    ("conflicts.csv", "volume,ac1,ac2,start_s,end_s,lat1,lon1,lat2,lon2\nlowc,A1,A2,x,1,0,0,0,0\n",
     "conflicts.csv: line 2"),
])
def test_a_bad_run_directory_is_refused_naming_the_file(run_dir, name, content, expected):
    path = run_dir / name
    if content is None:
        path.unlink()
    else:
        path.write_text(content)
    with pytest.raises(ReplayError, match=expected.replace("(", r"\(").replace(")", r"\)")):
        RunReplay(run_dir)


def test_a_live_frame_shows_conflict_states_and_the_events_that_began():
    sim = Simulation(seed=1)
    sim.services.start()
    # head-on at 500 ft, 1,001 m apart, 40 kt each (closing 41.2 m/s): LoWC (450 m) from 13.4 s, NMAC
    # (150 m) only from 20.6 s
    sim.stack("CRE P1 EC35 40.0 -74.0 90 500 40")
    sim.stack("CRE P2 EC35 40.0 -73.98826 270 500 40")
    before = frame_from_sim(sim)
    assert before.status.tolist() == [STATUS_NORMAL, STATUS_NORMAL]
    sim.run_until(16.0)
    f = frame_from_sim(sim, events_since=0.0)
    assert f.ids == ("P1", "P2")
    assert f.status.tolist() == [STATUS_LOWC, STATUS_LOWC]
    assert [e.kind for e in f.events] == ["lowc"]
    assert f.metrics["lowc"] == 1 and f.metrics["airborne"] == 2
    np.testing.assert_allclose(f.lat, sim.view.lat)
    assert frame_from_sim(sim, events_since=16.0).events == ()
    assert f.advisories == {}
    record_advisory(sim, "P2", "slow down")  # what a use case's action or a resolution service records
    advised = frame_from_sim(sim)
    assert advised.advisories == {"P2": "slow down at 16 s"}
    assert advised.to_json()["advisories"] == {"P2": "slow down at 16 s"}


def test_coastlines_are_read_from_bluesky_navdata_and_cut_to_the_map(tmp_path, monkeypatch):
    import aamsim.viewer.coastline as coast

    (tmp_path / "coastlines.dat").write_text(
        "M 40.0 -74.5\nD 40.0 -74.2\nD 40.0 -74.0\nD 40.0 -73.0\nD 40.0 -72.0\n"  # crosses the map
        "M 10.0 10.0\nD 10.5 10.5\n"                                             # far away
        "M 40.05 -74.01\nbad line\nD 40.06 x\nD 40.07 -74.02\n")                # garbage lines skipped
    monkeypatch.setattr(coast, "navdata_dir", lambda: tmp_path)
    coast._all_lines.cache_clear()
    try:
        lines = coast.coastlines((39.9, 40.1, -74.1, -73.9), margin_deg=0.1)
        # the crossing line keeps its points inside the widened box plus one on either side
        np.testing.assert_array_equal(lines[0], [[40.0, -74.2], [40.0, -74.0], [40.0, -73.0]])
        np.testing.assert_array_equal(lines[1], [[40.05, -74.01], [40.07, -74.02]])
        assert len(lines) == 2
        assert layout_from_scenario(SCENARIO).outline[0].shape == (3, 2)
        assert layout_from_scenario(SCENARIO, coastline=False).outline == ()
        monkeypatch.setattr(coast, "navdata_dir", lambda: None)  # no BlueSky installed: no coastline
        coast._all_lines.cache_clear()
        assert coast.coastlines((39.9, 40.1, -74.1, -73.9)) == ()
    finally:
        coast._all_lines.cache_clear()


def test_the_new_york_map_has_bluesky_s_coastline_when_bluesky_is_installed():
    pytest.importorskip("bluesky", reason="bluesky-simulator is not installed (the test extra installs it)")
    from aamsim.scenarios import resolve_scenario

    path = resolve_scenario("nyc_train_100.scn")
    assert path is not None
    layout = layout_from_scenario(path.read_text())
    assert len(layout.outline) >= 3  # the coasts around the Hudson, the East River and the bay
    lat0, lat1, lon0, lon1 = layout.bounds
    for line in layout.outline:
        inside = (line[:, 0] > lat0 - 0.1) & (line[:, 0] < lat1 + 0.1) & (line[:, 1] > lon0 - 0.1) & \
            (line[:, 1] < lon1 + 0.1)
        assert inside.any()  # every piece kept reaches into the map


def test_a_run_in_which_no_aircraft_flew_replays_as_an_empty_map(tmp_path):
    import warnings

    (tmp_path / "trajectories.csv").write_text(TRAJ_HEADER)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "input contained no data" from numpy either
        r = RunReplay(tmp_path)
    assert (r.t_start, r.t_end, len(r.frame_at(10.0))) == (0.0, 0.0, 0)
    from aamsim.render.video import write_run_video

    with pytest.raises(ValueError, match="no trajectory samples"):
        write_run_video(tmp_path, tmp_path / "v.mp4")


def test_an_aircraft_on_the_ground_is_neither_airborne_nor_holding():
    sim = Simulation(seed=1)
    sim.services.start()
    sim.stack("CRE G1 EC35 40.0 -74.0 90 0 0")  # parked on the ground
    sim.stack("CRE H1 EC35 40.1 -74.0 90 500 0")  # hovering at 500 ft
    sim.stack("CRE F1 EC35 40.2 -74.0 90 500 60")  # flying at 60 kt
    sim.run_until(5.0)
    f = frame_from_sim(sim)
    assert f.ids == ("G1", "H1", "F1")
    assert f.status.tolist() == [STATUS_NORMAL, STATUS_HOLDING, STATUS_NORMAL]
    assert f.metrics["airborne"] == 2 and f.metrics["holding"] == 1


def test_a_replayed_aircraft_on_the_ground_is_neither_airborne_nor_holding(tmp_path):
    rows = ["G1,10.00,40.0,-74.0,0.0,0.0,0.0,0.0,90.0,0.0",  # on the ground, standing
            "H1,10.00,40.1,-74.0,150.0,0.5,0.5,0.5,90.0,0.0"]  # hovering at 150 m
    (tmp_path / "trajectories.csv").write_text(TRAJ_HEADER + "\n".join(rows) + "\n")
    f = RunReplay(tmp_path).frame_at(10.0)
    assert f.ids == ("G1", "H1")
    assert f.status.tolist() == [STATUS_NORMAL, STATUS_HOLDING]
    assert f.metrics["airborne"] == 1 and f.metrics["holding"] == 1


def test_the_map_holds_where_aircraft_are_created_even_without_a_route():
    # A scenario of headings only (no waypoints): the first picture, before any aircraft exists, must
    # still frame the place where they will fly, not (0, 0).
    text = "00:00:10.00>CRE A1 EC35 40.70 -74.00 90 1000 100\n00:00:20.00>CRE A2 EC35 40.72 -73.95 270 1000 100\n"
    lat0, lat1, lon0, lon1 = layout_from_scenario(text, coastline=False).bounds
    assert lat0 < 40.70 and 40.72 < lat1 and lon0 < -74.00 and -73.95 < lon1
    assert lat1 - lat0 < 0.1 and lon1 - lon0 < 0.1
