"""Track building and interpolation: hand-computed cases, the real Zurich sample, properties."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim.realtraffic import StateReports, read_reports
from aamsim.realtraffic.tracks import build_tracks, wrap360

ZURICH = Path(__file__).parent / "data" / "opensky" / "switzerland_zurich_0600.json.gz"
REGA = ZURICH.with_name("rega_zh.json.gz")
R_EARTH = 6371000.0


def reports(*rows: tuple, icao24: str = "abc123") -> StateReports:
    """Rows of (t, lat, lon, alt, gs, trk, vs[, on_ground[, icao24]])."""
    def col(k, default=np.nan):
        return np.array([r[k] if len(r) > k else default for r in rows], dtype=float)

    return StateReports(
        t_s=col(0), icao24=np.array([r[8] if len(r) > 8 else icao24 for r in rows]),
        callsign=np.array(["TEST1"] * len(rows)), lat=col(1), lon=col(2), alt_m=col(3), gs_mps=col(4),
        trk_deg=col(5), vs_mps=col(6), on_ground=np.array([bool(r[7]) if len(r) > 7 else False for r in rows]),
    )


def test_interpolation_is_linear_and_turns_the_short_way():
    track = build_tracks(reports((0, 47.0, 8.0, 100, 50, 350, 1), (10, 47.1, 8.2, 200, 70, 10, 3)))[0]
    state = track.state_at(2.5)
    assert state == pytest.approx(
        {"lat": 47.025, "lon": 8.05, "alt_m": 125.0, "gs_mps": 55.0, "trk_deg": 355.0, "vs_mps": 1.5}
    )
    assert track.state_at(7.5)["trk_deg"] == pytest.approx(5.0)  # 350 + 0.75 * 20, past north
    assert track.state_at(10.0) == pytest.approx(
        {"lat": 47.1, "lon": 8.2, "alt_m": 200.0, "gs_mps": 70.0, "trk_deg": 10.0, "vs_mps": 3.0}
    )
    assert track.state_at(-0.1) is None and track.state_at(10.1) is None


def test_longitude_is_interpolated_across_the_antimeridian():
    track = build_tracks(reports((0, 60.0, 179.9, 9000, 250, 90, 0), (10, 60.0, -179.7, 9000, 250, 90, 0)))[0]
    assert track.state_at(2.5)["lon"] == pytest.approx(-179.999999999, abs=1e-6)  # 179.9 + 0.25 * 0.4 = 180
    assert track.state_at(5.0)["lon"] == pytest.approx(-179.9)


def test_gaps_split_tracks_and_landings_end_them():
    tracks = build_tracks(
        reports(
            (0, 47, 8, 100, 50, 90, 0), (10, 47, 8.01, 100, 50, 90, 0), (20, 47, 8.02, 100, 50, 90, 0),
            (100, 47, 8.1, 100, 50, 90, 0), (110, 47, 8.11, 100, 50, 90, 0),  # 80 s gap: a second track
            (120, 47, 8.12, 0, 0, 90, 0, True),  # landed
            (130, 47, 8.12, 50, 10, 90, 2), (140, 47, 8.13, 80, 20, 90, 3),  # took off again
        ),
        max_gap_s=30.0,
    )
    assert [(t.label, list(t.t_s)) for t in tracks] == [
        ("abc123", [0.0, 10.0, 20.0]), ("abc123-2", [100.0, 110.0]), ("abc123-3", [130.0, 140.0]),
    ]
    assert tracks.summary.on_ground == 1 and tracks.summary.tracks == 3
    assert list(tracks.labels) == ["abc123", "abc123-2", "abc123-3"]
    assert tracks.states_at(115.0).index.size == 0  # between the last airborne report and the landing
    assert tracks.time_span == (0.0, 140.0)


def test_repeated_reports_short_stretches_and_missing_altitudes_are_counted():
    tracks = build_tracks(
        reports(
            (0, 47, 8, 100, 50, 90, 0), (10, 47, 8.01, 100, 50, 90, 0),
            (10, 47, 8.02, 110, 50, 90, 0),  # the same time again: this later report wins
            (15, 47, 8.03, np.nan, 50, 90, 0),  # no altitude
            (500, 47, 8.5, 100, 50, 90, 0),  # alone after a gap: too short to interpolate
            (0, 46, 7, 100, 50, 90, 0, False, "def456"), (5, 46, 7.01, 100, 50, 90, 0, False, "def456"),
        )
    )
    assert tracks.summary.same_time == 1 and tracks.summary.no_altitude == 1
    assert tracks.summary.short_tracks == 1 and tracks.summary.in_short_tracks == 1
    assert tracks.summary.reports == 7 and [t.icao24 for t in tracks] == ["abc123", "def456"]
    assert tracks[0].lon[1] == 8.02 and tracks[0].alt_m[1] == 110


def test_missing_speed_and_track_are_filled_from_neighbours_or_derived_from_positions():
    tracks = build_tracks(
        reports(
            (0, 47, 8, 100, 50, 90, 0), (10, 47, 8.01, 100, np.nan, np.nan, np.nan), (20, 47, 8.02, 100, 60, 95, 1),
            (0, 0.0, 0.0, 100, np.nan, np.nan, np.nan, False, "def456"),
            (10, 0.01, 0.0, 150, np.nan, np.nan, np.nan, False, "def456"),
        )
    )
    first, second = tracks
    assert (first.gs_mps[1], first.trk_deg[1], first.vs_mps[1]) == (50, 90, 0)  # the report before
    # Derived: 0.01 deg of latitude north in 10 s = 0.01 * pi / 180 * 6371 km / 10 s = 111.19 m/s.
    assert second.gs_mps == pytest.approx([0.01 * math.pi / 180 * R_EARTH / 10] * 2)
    assert second.trk_deg == pytest.approx([0.0, 0.0]) and second.vs_mps == pytest.approx([5.0, 5.0])


def test_states_at_for_all_tracks_equals_each_tracks_own_state_on_the_zurich_sample():
    tracks = build_tracks(read_reports(ZURICH), max_gap_s=60.0)
    # 24 aircraft, one of them seen once in the box: 23 tracks and one report counted as too short.
    assert len(tracks) == 23 and tracks.summary.short_tracks == 1 and tracks.summary.reports == 531
    t0, t1 = tracks.time_span
    for t in np.linspace(t0, t1, 37):
        states = tracks.states_at(float(t))
        assert len(states) == len([tr for tr in tracks if tr.t_s[0] <= t <= tr.t_s[-1]])
        for k, i in enumerate(states.index):
            own = tracks[int(i)].state_at(float(t))
            assert own is not None
            for name, value in own.items():
                assert getattr(states, name)[k] == pytest.approx(value, abs=1e-9), name


def test_the_rega_helicopter_is_one_track_and_its_state_is_interpolated_between_real_reports():
    tracks = build_tracks(read_reports(REGA))
    assert len(tracks) == 1 and tracks[0].callsign == "REGA1" and len(tracks[0].t_s) == 339
    # Halfway between the first two reports (1 s apart): lat 47.3665008545 -> 47.3664830095,
    # lon 8.5006713867 -> 8.5010235126, altitude 1950 ft both.
    state = tracks.states_at(1558732719.5)
    assert state.lat[0] == pytest.approx((47.3665008545 + 47.3664830095) / 2, abs=1e-12)
    assert state.lon[0] == pytest.approx((8.5006713867 + 8.5010235126) / 2, abs=1e-12)
    assert state.alt_m[0] == pytest.approx(594.36)


@settings(max_examples=100, deadline=None)
@given(
    times=st.lists(st.floats(0, 1e5), min_size=2, max_size=12, unique=True),
    tracks_deg=st.lists(st.floats(0, 359.99), min_size=12, max_size=12),
    frac=st.floats(0, 1),
)
def test_states_at_report_times_are_the_reports_and_track_angles_stay_in_range(times, tracks_deg, frac):
    times = sorted(times)
    rows = [(t, 40 + i * 1e-3, 5 - i * 1e-3, 100 + i, 30, tracks_deg[i], 0) for i, t in enumerate(times)]
    built = build_tracks(reports(*rows), max_gap_s=1e6)
    assert len(built) == 1
    for t, lat, lon, alt, _, trk, _ in rows:
        state = built.states_at(t)
        assert state.lat[0] == pytest.approx(lat) and state.alt_m[0] == pytest.approx(alt)
        assert state.trk_deg[0] == pytest.approx(trk, abs=1e-9) or abs(state.trk_deg[0] - trk) == pytest.approx(360)
    t = times[0] + frac * (times[-1] - times[0])
    state = built.states_at(t)
    assert 0.0 <= state.trk_deg[0] < 360.0 and min(r[3] for r in rows) <= state.alt_m[0] <= max(r[3] for r in rows)


def test_track_angles_stay_below_360_for_tiny_negative_angles():
    # Found by the property above: np.mod(-5e-324, 360) is 360.0, not an angle in [0, 360).
    assert list(wrap360(np.array([-5e-324, -1e-300, 360.0, 359.5, -0.5]))) == [0.0, 0.0, 0.0, 359.5, 359.5]
    built = build_tracks(reports((0, 47, 8, 100, 50, 0.0, 0), (1, 47, 8, 100, 50, 180.0, 0)))
    assert built.states_at(5e-324).trk_deg[0] == 0.0


def test_tracks_built_from_a_streaming_reader_equal_those_from_the_whole_recording():
    from aamsim.realtraffic import RecordingReader

    whole = build_tracks(read_reports(ZURICH))
    streamed = build_tracks(RecordingReader(ZURICH, chunk_rows=17))
    assert streamed.summary == whole.summary
    for a, b in zip(whole, streamed, strict=True):
        assert a.label == b.label and a.callsign == b.callsign
        np.testing.assert_array_equal(a.t_s, b.t_s)
        np.testing.assert_array_equal(a.lat, b.lat)
