"""Small recordings cannot make a replay take gigabytes or end a run (issue 26, items 7 and 8).

A 2.5 MB recording with one long callsign took 5.2 GB (every callsign as wide as it); a 1.3 MB gzip
holding 20 million rows was read whole because its size on disk was compared with the streaming
threshold; a deeply nested JSON recording ended the run with RecursionError and no outputs.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

from aamsim import Simulation
from aamsim.realtraffic import RecordingError, RecordingReader, read_reports
from aamsim.realtraffic.readers import decoded_size_above
from aamsim.realtraffic.replay import RecordingFeed
from aamsim.realtraffic.reports import MAX_CALLSIGN_CHARS

HEADER = "time,icao24,lat,lon,velocity,heading,vertrate,callsign,onground,baroaltitude\n"


def _row(k: int, callsign: str = "REGA1") -> str:
    return f"{1_558_732_719 + k},4b43ac,47.{3665 + k},8.5006,26.3,93.4,3.9,{callsign},false,594.4\n"


def test_a_callsign_longer_than_a_callsign_skips_its_row_and_keeps_the_array_narrow(tmp_path: Path) -> None:
    path = tmp_path / "r.csv"
    rows = [_row(k) for k in range(50)]
    rows[17] = _row(17, "C" * 20_000)
    path.write_text(HEADER + "".join(rows))
    reader = RecordingReader(path)
    reports = read_reports(path)
    list(reader)
    assert len(reports) == 49 and reports.callsign.dtype.itemsize <= 4 * MAX_CALLSIGN_CHARS
    assert [(s.row, s.reason) for s in reader.skipped.rows] == [
        ("19", f"callsign in column 'callsign' over {MAX_CALLSIGN_CHARS} characters")]


def test_a_callsign_of_the_longest_length_is_kept(tmp_path: Path) -> None:
    path = tmp_path / "r.csv"
    path.write_text(HEADER + _row(0, "Q" * MAX_CALLSIGN_CHARS) + _row(1))
    assert read_reports(path).callsign.tolist() == ["Q" * MAX_CALLSIGN_CHARS, "REGA1"]


def test_streaming_is_decided_on_the_decompressed_size(tmp_path: Path) -> None:
    path = tmp_path / "many.csv.gz"
    body = HEADER + "".join(_row(k % 10) for k in range(20_000))  # ~1.5 MB of text, a few kB of gzip
    path.write_bytes(gzip.compress(body.encode()))
    assert path.stat().st_size < 100_000 < len(body)
    assert decoded_size_above(path, 100_000) and not decoded_size_above(path, len(body))
    assert RecordingFeed(path, stream_above_bytes=100_000).streaming
    assert not RecordingFeed(path, stream_above_bytes=len(body)).streaming
    plain = tmp_path / "few.csv"
    plain.write_text(HEADER + _row(0))
    assert not decoded_size_above(plain, 1_000) and decoded_size_above(plain, 10)


def test_a_gzip_whose_trailer_lies_is_measured_by_decompressing(tmp_path: Path) -> None:
    path = tmp_path / "lie.csv.gz"
    data = bytearray(gzip.compress((HEADER + _row(0) * 5_000).encode()))
    data[-4:] = (10).to_bytes(4, "little")  # ISIZE: claims 10 bytes
    path.write_bytes(bytes(data))
    assert decoded_size_above(path, 100_000)


DEEP = "[" * 200_000 + "]" * 200_000


@pytest.mark.parametrize("name, text, skipped", [
    ("deep.jsonl", json.dumps({"time": 1, "icao24": "4b43ac", "lat": 1, "lon": 1, "baroaltitude": 1}) + "\n" + DEEP
     + "\n", 1),
    ("deep.json", "[" + DEEP + "]", None),
    ("deep2.json", "{\n" + '"a": ' + DEEP + "\n}", None),
])
def test_deeply_nested_json_is_a_skipped_row_or_a_recording_error(tmp_path: Path, name: str, text: str,
                                                                   skipped: int | None) -> None:
    path = tmp_path / name
    path.write_text(text)
    reader = RecordingReader(path)
    if skipped is None:
        with pytest.raises(RecordingError, match="nested too deep"):
            list(reader)
    else:
        assert sum(len(b) for b in reader) == 1 and reader.skipped.total == skipped
        assert "nested too deep" in reader.skipped.rows[0].reason


def test_a_replay_of_a_deeply_nested_recording_is_an_error_and_the_run_goes_on(tmp_path: Path) -> None:
    (tmp_path / "deep.json").write_text("[" + DEEP + "]")
    scn = tmp_path / "s.scn"
    scn.write_text("00:00:00.00>REPLAY deep.json\n00:00:00.00>CRE A B744 0 0 0 FL100 250\n00:00:10.00>ECHO done\n")
    sim = Simulation(use_bluesky_navdata=False)
    sim.load_scenario(scn)
    sim.run_until(20.0)
    assert any("nested too deep" in m.text for m in sim.reporter.errors())
    assert any(m.text == "done" for m in sim.reporter.messages) and sim.simt == pytest.approx(20.0)
