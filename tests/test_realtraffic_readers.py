"""Readers of real-traffic recordings: genuine OpenSky samples, every format, units, errors, streaming.

The recordings under tests/data/opensky are real (see its README); the other formats are
written here from the same genuine rows, so every format must give the very same SI reports.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import sys
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim.realtraffic import (
    RecordingError,
    RecordingReader,
    SkipLog,
    StateReports,
    detect_format,
    plan_columns,
    read_reports,
)
from aamsim.realtraffic.sources import _array_records, csv_chunks

DATA = Path(__file__).parent / "data" / "opensky"
REGA = DATA / "rega_zh.json.gz"
ZURICH = DATA / "switzerland_zurich_0600.json.gz"
FT, KT, FPM = 0.3048, 1852.0 / 3600.0, 0.3048 / 60.0


def rega_rows(n: int | None = None) -> list[dict]:
    rows = json.loads(gzip.decompress(REGA.read_bytes()))
    return rows if n is None else rows[:n]


def test_the_rega_helicopter_sample_reads_in_si_units():
    reports = read_reports(REGA)
    assert len(reports) == 339 and set(reports.icao24) == {"4b43ac"} and set(reports.callsign) == {"REGA1"}
    # First record, by hand: timestamp 1558732719000 ms = 2019-05-24 21:18:39 UTC, altitude 1950 ft,
    # groundspeed 51.0881149611 kt, vertical_rate 768 ft/min, track 93.3664606634 deg.
    assert reports.t_s[0] == 1558732719.0
    assert datetime.fromtimestamp(reports.t_s[0], UTC) == datetime(2019, 5, 24, 21, 18, 39, tzinfo=UTC)
    assert reports.lat[0] == 47.3665008545 and reports.lon[0] == 8.5006713867
    assert reports.alt_m[0] == pytest.approx(594.36, abs=1e-9)  # 1950 * 0.3048
    assert reports.gs_mps[0] == pytest.approx(26.281997, abs=1e-6)  # 51.0881149611 * 1852 / 3600
    assert reports.vs_mps[0] == pytest.approx(3.90144, abs=1e-9)  # 768 * 0.3048 / 60
    assert reports.trk_deg[0] == 93.3664606634 and not reports.on_ground.any()
    # Last record: 21:24:17 UTC, altitude 1450 ft, vertical_rate 128 ft/min.
    assert reports.t_s[-1] == 1558733057.0
    assert reports.alt_m[-1] == pytest.approx(441.96, abs=1e-9) and reports.vs_mps[-1] == pytest.approx(0.65024)
    assert np.all(np.diff(reports.t_s) > 0)


def test_altitude_choice_and_detected_units_are_reported():
    reader = RecordingReader(REGA, altitude="geo")
    first = next(iter(reader))
    assert first.alt_m[0] == pytest.approx(662.94, abs=1e-9)  # geoaltitude 2175 ft, a traffic-library file
    assert reader.plan is not None and reader.plan.family == "traffic"
    assert reader.plan.fields["alt"] == ("geoaltitude", "ft") and reader.plan.fields["vs"] == ("vertical_rate", "ft/min")
    assert reader.plan.fields["t"] == ("timestamp", "epoch")


def test_the_zurich_extract_gives_24_aircraft_sorted_by_time():
    reports = read_reports(ZURICH)
    assert len(reports) == 531 and len(set(reports.icao24)) == 24
    assert np.all(np.diff(reports.t_s) >= 0)
    assert reports.t_s[0] >= datetime(2018, 8, 1, 6, tzinfo=UTC).timestamp()
    assert reports.t_s[-1] < datetime(2018, 8, 1, 7, tzinfo=UTC).timestamp()
    iberia = reports.take(reports.callsign == "IBE3195")
    # Its first report in the file: 37000 ft, 419.0581064367 kt at 2018-08-01 06:00:20 UTC.
    assert iberia.t_s[0] == 1533103220.0 and iberia.alt_m[0] == pytest.approx(11277.6)
    assert iberia.gs_mps[0] == pytest.approx(419.0581064367 * KT)
    assert np.all((reports.lat >= 47.2) & (reports.lat <= 47.7) & (reports.lon >= 8.2) & (reports.lon <= 8.9))


# ---- the same genuine rows in every format ---------------------------------------------------


def opensky_si_row(r: dict) -> dict:
    """A traffic-library record as a state_vectors_data4 row (SI, OpenSky names)."""
    return {
        "time": r["timestamp"] // 1000, "icao24": r["icao24"], "lat": r["latitude"], "lon": r["longitude"],
        "velocity": r["groundspeed"] * KT, "heading": r["track"], "vertrate": r["vertical_rate"] * FPM,
        "callsign": r["callsign"] + "   ", "onground": "true" if r["onground"] else "false", "alert": "false",
        "spi": "false", "squawk": r["squawk"], "baroaltitude": r["altitude"] * FT,
        "geoaltitude": r["geoaltitude"] * FT, "lastposupdate": r["last_position"] / 1000, "lastcontact": 0,
        "hour": r["hour"],
    }


def rest_state(r: dict) -> list:
    """A traffic-library record in the documented states/all array layout (SI)."""
    return [
        r["icao24"], r["callsign"].ljust(8), "Switzerland", r["timestamp"] // 1000, r["timestamp"] // 1000,
        r["longitude"], r["latitude"], r["altitude"] * FT, r["onground"], r["groundspeed"] * KT, r["track"],
        r["vertical_rate"] * FPM, None, r["geoaltitude"] * FT, str(r["squawk"]), r["spi"], 0,
    ]


def write_csv(path: Path, rows: list[dict]) -> Path:
    with open(path, "w", newline="") as out:
        writer = csv.DictWriter(out, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return path


def formats(tmp: Path, rows: list[dict]) -> dict[str, Path]:
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    files = {}
    si = [opensky_si_row(r) for r in rows]
    files["opensky csv"] = write_csv(tmp / "states.csv", si)
    with gzip.open(tmp / "states.csv.gz", "wt", newline="") as out:
        out.write((tmp / "states.csv").read_text())
    files["opensky csv.gz"] = tmp / "states.csv.gz"
    iso = [{"": i, **r, "timestamp": datetime.fromtimestamp(r["timestamp"] / 1000, UTC).isoformat(sep=" ")}
           for i, r in enumerate(rows)]
    files["traffic to_csv (ISO times, index column)"] = write_csv(tmp / "traffic.csv", iso)
    files["traffic jsonl"] = tmp / "traffic.jsonl"
    files["traffic jsonl"].write_text("".join(json.dumps(r) + "\n" for r in rows))
    columns = {key: {str(i): r[key] for i, r in enumerate(rows)} for key in rows[0]}
    files["pandas orient=columns"] = tmp / "columns.json"
    files["pandas orient=columns"].write_text(json.dumps(columns, indent=1))
    files["pretty records array"] = tmp / "pretty.json"
    files["pretty records array"].write_text(json.dumps(rows, indent=2))
    halves = [rows[: len(rows) // 2], rows[len(rows) // 2 :]]
    responses = [{"time": h[-1]["timestamp"] // 1000, "states": [rest_state(r) for r in h]} for h in halves]
    files["rest response"] = tmp / "states_all.json"
    files["rest response"].write_text(json.dumps({"time": 0, "states": [rest_state(r) for r in rows]}, indent=1))
    files["rest responses, one per line"] = tmp / "polls.jsonl"
    files["rest responses, one per line"].write_text("".join(json.dumps(r) + "\n" for r in responses))
    stamps = pa.array([r["timestamp"] * 1_000_000 for r in rows], pa.timestamp("ns", tz="UTC"))
    table = pa.table({"timestamp": stamps, **{k: [r[k] for r in rows] for k in rows[0] if k != "timestamp"}})
    files["traffic parquet"] = tmp / "traffic.parquet"
    pq.write_table(table, files["traffic parquet"])
    files["opensky parquet"] = tmp / "states.parquet"
    pq.write_table(pa.Table.from_pylist(si), files["opensky parquet"])
    files["no suffix (sniffed parquet)"] = tmp / "recording"
    files["no suffix (sniffed parquet)"].write_bytes(files["traffic parquet"].read_bytes())
    return files


def test_every_format_gives_the_same_reports_as_the_traffic_sample(tmp_path):
    rows = rega_rows(60)
    expected = read_reports(REGA).take(slice(0, 60))
    for name, path in formats(tmp_path, rows).items():
        got = read_reports(path)
        assert len(got) == 60, name
        for field in ("t_s", "lat", "lon", "alt_m", "gs_mps", "trk_deg", "vs_mps"):
            np.testing.assert_allclose(getattr(got, field), getattr(expected, field), rtol=1e-12, err_msg=name)
        assert list(got.icao24) == ["4b43ac"] * 60 and list(got.callsign) == ["REGA1"] * 60, name
        assert not got.on_ground.any(), name


def test_formats_are_detected_from_names_and_content(tmp_path):
    files = formats(tmp_path, rega_rows(3))
    assert detect_format(files["opensky csv.gz"]) == "csv"
    assert detect_format(files["traffic jsonl"]) == "json"
    assert detect_format(files["no suffix (sniffed parquet)"]) == "parquet"
    (tmp_path / "data").write_text('[{"a": 1}]')
    assert detect_format(tmp_path / "data") == "json"


# ---- column names, units, errors ------------------------------------------------------------


def small_csv(tmp_path: Path, header: str, *lines: str) -> Path:
    path = tmp_path / "rec.csv"
    path.write_text("\n".join([header, *lines]) + "\n")
    return path


@pytest.mark.parametrize(
    ("header", "column", "words"),
    [
        ("time,icao24,lat,lon,baroaltitude,wind", "wind", "unknown column"),
        ("time,icao24,lat,lon,baroaltitude,groundspeed", "groundspeed", "mixed units"),
        ("time,icao24,lon,baroaltitude", "lat", "no position"),
        ("time,icao24,latitude,baroaltitude", "lon", "no position"),
        ("time,icao24,lat,lon,geoaltitude,vertical_rate", "geoaltitude", "units="),
        ("time,icao24,lat,latitude,lon,baroaltitude", "latitude", "like column 'lat'"),
        ("time,icao24,lat,lon,baroaltitude,LAT", "lat", "appears twice"),
    ],
)
def test_bad_columns_are_refused_naming_file_and_column(tmp_path, header, column, words):
    path = small_csv(tmp_path, header, "1,abcdef," + ",".join(["1"] * (header.count(",") - 1)))
    with pytest.raises(RecordingError) as caught:
        read_reports(path)
    assert caught.value.path == str(path) and caught.value.column == column
    assert str(path) in str(caught.value) and repr(column) in str(caught.value) and words in str(caught.value)


def test_files_without_time_icao24_or_altitude_are_refused(tmp_path):
    for header, words in [("icao24,lat,lon,altitude", "no time"), ("time,lat,lon,altitude", "no 'icao24'"),
                          ("time,icao24,lat,lon", "no altitude")]:
        with pytest.raises(RecordingError, match=words):
            read_reports(small_csv(tmp_path, header, "1,2,3,4"))


def test_units_override_reads_pyopensky_si_output_and_extra_columns_can_be_allowed(tmp_path):
    # pyopensky's history(..., nautical_units=False): traffic names, SI values.
    header = "timestamp,icao24,latitude,longitude,altitude,groundspeed,track,vertical_rate,flight_id,note"
    path = small_csv(tmp_path, header, "1533103220,342441,47.5,8.5,1000,100,90,5,x,y")
    with pytest.raises(RecordingError, match="unknown column") as caught:
        read_reports(path, units={"altitude": "m", "groundspeed": "m/s", "vertical_rate": "m/s"})
    assert caught.value.column == "note"
    got = read_reports(
        path, units={"altitude": "m", "groundspeed": "m/s", "vertical_rate": "m/s"}, ignore_columns=["note"]
    )
    assert (got.alt_m[0], got.gs_mps[0], got.vs_mps[0]) == (1000.0, 100.0, 5.0)
    got = read_reports(path, allow_unknown_columns=True)  # names alone: traffic units
    assert got.alt_m[0] == pytest.approx(304.8) and got.vs_mps[0] == pytest.approx(5 * FPM)
    with pytest.raises(RecordingError, match="not one of m, ft"):
        read_reports(path, units={"altitude": "km"}, allow_unknown_columns=True)
    with pytest.raises(RecordingError, match="does not use"):
        read_reports(path, units={"baroaltitude": "m"}, allow_unknown_columns=True)


def test_malformed_rows_are_skipped_with_file_and_row_and_nothing_else_is_lost(tmp_path):
    header = "time,icao24,lat,lon,baroaltitude,velocity,heading,vertrate,onground,callsign"
    path = small_csv(
        tmp_path, header,
        "100,4b43ac,47.0,8.0,500,50,90,0,false,REGA1",  # line 2: good
        "101,4b43ac,north,8.0,500,50,90,0,false,REGA1",  # 3: bad latitude
        "102,4b43ac,47.0,8.0,500,50,90,0,false",  # 4: a field short
        "103,zzzzzz,47.0,8.0,500,50,90,0,false,REGA1",  # 5: bad icao24
        "104,4b43ac,,,500,50,90,0,false,REGA1",  # 6: no position (a REST-style null)
        "soon,4b43ac,47.0,8.0,500,50,90,0,false,REGA1",  # 7: bad time
        "106,4b43ac,47.0,8.0,high,50,90,-inf,false,REGA1",  # 8: bad altitude (the first bad field)
        "107,4b43ac,47.0,8.0,500,50,90,0,maybe,REGA1",  # 9: bad on-ground flag
        "108,4b43ac,95.0,8.0,500,50,90,0,false,REGA1",  # 10: latitude out of range
        "",  # a blank line is nothing
        "109,4b43ac,47.0,8.0,500,inf,90,0,false,REGA1",  # 12: infinite speed
        "110,4b43ac,47.1,8.1,,,,nan,true,",  # 13: good, on the ground, unknowns as NaN
    )
    reader = RecordingReader(path, chunk_rows=3)
    reports = read_all(reader)
    assert sorted(str(s) for s in reader.skipped.rows) == sorted([
        f"{path}:3: bad latitude or longitude",
        f"{path}:4: 9 fields where the header has 10",
        f"{path}:5: bad icao24 in column 'icao24'",
        f"{path}:6: no position",
        f"{path}:7: bad time in column 'time'",
        f"{path}:8: bad value in column 'baroaltitude'",
        f"{path}:9: bad value in column 'onground'",
        f"{path}:10: latitude outside [-90, 90]",
        f"{path}:12: bad value in column 'velocity'",
    ])
    assert reader.skipped.total == 9 and reader.rows_read == 2
    assert list(reports.t_s) == [100.0, 110.0] and list(reports.on_ground) == [False, True]
    assert np.isnan(reports.alt_m[1]) and np.isnan(reports.gs_mps[1]) and reports.callsign[1] == ""
    assert "1 x no position (first at" in reader.skipped.summary()


def read_all(reader: RecordingReader) -> StateReports:
    """Every block of ``reader`` in one, sorted by time."""
    return StateReports.concat(list(reader)).sorted_by_time()


def test_rest_responses_skip_states_without_position_and_short_state_vectors(tmp_path):
    rows = rega_rows(2)
    good = rest_state(rows[0])
    no_position = rest_state(rows[1])
    no_position[3] = no_position[5] = no_position[6] = None  # time_position, lon, lat null
    response = {"time": 1558732720, "states": [good, no_position, good[:10], "x"]}
    lines = [json.dumps(response), "{broken", json.dumps({"time": 1558732721, "states": None})]
    path = tmp_path / "polls.jsonl"
    path.write_text("\n".join(lines) + "\n")
    reader = RecordingReader(path)
    reports = read_all(reader)
    assert len(reports) == 1 and reports.alt_m[0] == pytest.approx(594.36) and reports.callsign[0] == "REGA1"
    assert sorted(str(s) for s in reader.skipped.rows) == sorted([
        f"{path}:1:2: no time",
        f"{path}:1:3: state vector of 10 fields, the layout has 17",
        f"{path}:1:4: state vector of str fields, the layout has 17",
        f"{path}:2: broken JSON: Expecting property name enclosed in double quotes",
    ])


def test_broken_json_array_is_an_error_naming_file_and_record(tmp_path):
    path = tmp_path / "cut.json"
    text = json.dumps(rega_rows(3))
    path.write_text(text[: len(text) - 40])  # cut inside the third record
    with pytest.raises(RecordingError, match=r"cut.json: broken JSON in record 3"):
        read_reports(path)
    path.write_text(json.dumps(rega_rows(2)).replace("}, {", "} {"))
    with pytest.raises(RecordingError, match="after record 1"):
        read_reports(path)


def test_reading_parquet_without_pyarrow_names_the_extra(tmp_path, monkeypatch):
    path = formats(tmp_path, rega_rows(2))["traffic parquet"]
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # what an install without pyarrow looks like
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(RecordingError, match=r"aamsim\[realtraffic\]"):
        read_reports(path)


# ---- streaming ------------------------------------------------------------------------------


@pytest.mark.parametrize("chunk_rows", [1, 7, 100000])
def test_chunked_reading_gives_the_same_reports_in_blocks_no_larger_than_asked(tmp_path, chunk_rows):
    whole = read_reports(ZURICH)
    for path in [ZURICH, *formats(tmp_path, rega_rows(40)).values()]:
        blocks = list(RecordingReader(path, chunk_rows=chunk_rows))
        assert max(len(b) for b in blocks) <= chunk_rows
        if path == ZURICH:
            assert len(blocks) == -(-531 // chunk_rows)
            joined = read_all(RecordingReader(path, chunk_rows=chunk_rows))
            np.testing.assert_array_equal(joined.t_s, whole.t_s)
            np.testing.assert_array_equal(joined.alt_m, whole.alt_m)


def test_bbox_and_time_window_are_applied_while_streaming():
    reader = RecordingReader(ZURICH, chunk_rows=50, bbox=(47.4, 8.4, 47.5, 8.6), t_window=(1533103200, 1533105000))
    kept = read_all(reader)
    assert 0 < len(kept) < 531 and reader.rows_outside == 531 - len(kept)
    assert np.all((kept.lat >= 47.4) & (kept.lat <= 47.5) & (kept.lon >= 8.4) & (kept.lon <= 8.6))
    assert kept.t_s.max() <= 1533105000
    everything = read_reports(ZURICH, bbox=(-90, 170, 90, 169))  # lon_min > lon_max: all but (169, 170)
    assert len(everything) == 531


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=3),
    max_leaves=8,
)


@settings(max_examples=150, deadline=None)
@given(records=st.lists(json_values, max_size=8), block=st.integers(1, 40), indent=st.sampled_from([None, 1]))
def test_the_incremental_array_decoder_matches_json_loads(records, block, indent):
    text = json.dumps(records, indent=indent)
    assert list(_array_records("x.json", io.StringIO(text), block=block)) == records


def test_streaming_reads_no_further_than_the_first_block_needs():
    rows = rega_rows() * 40  # 13,560 genuine records, ~4.6 MB of JSON
    text = json.dumps(rows)
    stream = io.StringIO(text)
    records = _array_records("big.json", stream)
    assert next(records) == rows[0]
    assert stream.tell() <= 1 << 20 < len(text) // 4  # one 1 MB buffer read, not the file
    csv_text = io.StringIO()
    writer = csv.DictWriter(csv_text, fieldnames=list(opensky_si_row(rows[0])))
    writer.writeheader()
    writer.writerows(opensky_si_row(r) for r in rows)
    stream = io.StringIO(csv_text.getvalue())
    plan = plan_columns("big.csv", list(opensky_si_row(rows[0])))
    chunks = csv_chunks("big.csv", stream, lambda names: plan, 100, SkipLog())
    assert next(chunks).size == 100
    assert stream.tell() < len(csv_text.getvalue()) // 100  # about the first 101 lines


cell = st.one_of(st.just(""), st.text(st.characters(blacklist_categories=("Cs",)), max_size=6))


@settings(max_examples=60, deadline=None)
@given(rows=st.lists(st.tuples(st.booleans(), st.integers(0, 5), cell), min_size=1, max_size=30))
def test_every_csv_row_is_a_report_or_a_reported_skip(tmp_path_factory, rows):
    """Good rows, and rows with one field replaced by arbitrary text: nothing is lost unaccounted."""
    good = ["1558732719", "4b43ac", "47.3665", "8.5007", "594.36", "REGA1"]
    lines, expected_alts = [], []
    for intact, field, junk in rows:
        values = list(good)
        values[4] = str(100.0 + len(lines))
        if not intact:
            values[field] = junk
        lines.append(values)
    path = tmp_path_factory.mktemp("csv") / "r.csv"
    with open(path, "w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow(["time", "icao24", "lat", "lon", "baroaltitude", "callsign"])
        writer.writerows(lines)
    reader = RecordingReader(path, chunk_rows=4)
    reports = read_all(reader)
    assert reader.rows_read + reader.skipped.total == len(lines)
    for (intact, field, _), values in zip(rows, lines, strict=True):
        if intact or field == 5:  # any text is a callsign
            expected_alts.append(float(values[4]))
    assert set(expected_alts) <= set(reports.alt_m)


def test_a_json_lines_file_with_a_broken_first_line_loses_that_line_only(tmp_path):
    path = tmp_path / "rega.jsonl"
    path.write_text('{"timestamp": 155873\n' + "".join(json.dumps(r) + "\n" for r in rega_rows(5)))
    reader = RecordingReader(path)
    assert len(read_all(reader)) == 5
    assert [str(s) for s in reader.skipped.rows] == [f"{path}:1: broken JSON: Expecting ',' delimiter"]


def test_reading_a_recording_twice_counts_its_rows_once(tmp_path):
    path = small_csv(tmp_path, "time,icao24,lat,lon,altitude", "1,4b43ac,47,8,100", "2,4b43ac,north,8,100")
    reader = RecordingReader(path)
    first, second = read_all(reader), read_all(reader)
    assert len(first) == len(second) == 1 and reader.rows_read == 1 and reader.skipped.total == 1


OPENSKY_HEADER = ["time", "icao24", "lat", "lon", "velocity", "heading", "vertrate", "callsign", "onground", "alert",
                  "spi", "squawk", "baroaltitude", "geoaltitude", "lastposupdate", "lastcontact", "hour"]


@settings(max_examples=80, deadline=None)
@given(order=st.permutations(OPENSKY_HEADER), upper=st.lists(st.booleans(), min_size=17, max_size=17),
       pad=st.sampled_from(["", " ", "\t"]))
def test_column_order_case_and_blanks_do_not_change_the_plan(order, upper, pad):
    names = [pad + (n.upper() if u else n) + pad for n, u in zip(order, upper, strict=True)]
    plan = plan_columns("x.csv", names)
    fields = {field: (column.strip().lower(), unit) for field, (column, unit) in plan.fields.items()}
    assert fields == {
        "t": ("time", "s"), "icao24": ("icao24", None), "lat": ("lat", "deg"), "lon": ("lon", "deg"),
        "gs": ("velocity", "m/s"), "trk": ("heading", "deg"), "vs": ("vertrate", "m/s"),
        "callsign": ("callsign", None), "on_ground": ("onground", None), "alt": ("baroaltitude", "m"),
    }
    assert plan.family == "opensky"
