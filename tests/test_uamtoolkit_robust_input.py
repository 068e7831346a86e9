"""uam2scn keeps every good row (issue 19, item 9): broken quotes, encodings, absurd times, large files."""

from __future__ import annotations

import io
import math
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from uam_helpers import GOOD_ROWS, HEADER, created_callsigns, run_module

from aamsim import Simulation
from uamtoolkit_import.convert import ConvertOptions, convert
from uamtoolkit_import.netfile import nyc_network
from uamtoolkit_import.schedule import parse_schedule, read_schedule
from uamtoolkit_import.times import MAX_SCHEDULE_TIME_S, TimeParseError, parse_schedule_time

NET = nyc_network()


def good_rows(n: int) -> list[str]:
    """``n`` distinct good rows (the three hand-checked flights with new ids, a minute apart)."""
    rows = []
    for k in range(n):
        cells = GOOD_ROWS[k % 3].split(",")
        cells[0] = f"G{k:03d}"
        cells[5] = f"{8 + k // 60:02d}:{k % 60:02d}:00"
        cells[6] = ""  # no scheduled arrival: any departure is valid
        rows.append(",".join(cells))
    return rows


def convert_cli(tmp_path: Path, name: str, data: bytes):
    src, out = tmp_path / name, tmp_path / (name + ".scn")
    src.write_bytes(data)
    proc = run_module("uamtoolkit_import", str(src), "-o", str(out))
    return proc, src, out


# ------------------------------------------------------------------------------ broken quotes
def test_an_unterminated_quote_costs_only_its_own_row_through_the_cli(tmp_path):
    rows = good_rows(140)
    rows.insert(2, 'BAD1,N009,EVTOL4,DMH,W30,"08:00:00,,DMH W30,120,500,2,10')  # line 4: quote never closed
    proc, src, out = convert_cli(tmp_path, "quote.csv", ("\n".join([HEADER, *rows]) + "\n").encode())
    assert proc.returncode == 0, proc.stderr
    assert "140 flights written, 1 skipped" in proc.stdout
    assert re.search(rf"{re.escape(str(src))}:4: field '\*': unreadable CSV row", proc.stderr)
    assert len(created_callsigns(out.read_text())) == 140


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 12), st.text(alphabet='ab,"\r\n 9', max_size=20))
def test_one_bad_line_never_swallows_the_rows_after_it(position, junk):
    """Whatever one line holds (quotes, commas, stray CR), every other good row is read."""
    rows = good_rows(12)
    bad = 'X1,"' + junk.replace("\n", " ").replace("\r", " ")  # an open quote, then anything on the line
    lines = [HEADER, *rows[:position], bad, *rows[position:]]
    sched = parse_schedule(io.StringIO("\n".join(lines) + "\n", newline=""), NET, "p.csv")
    assert [f.flight_id for f in sched.flights] == [f"G{k:03d}" for k in range(12)]
    assert {e.row for e in sched.errors} == {position + 2}


# ---------------------------------------------------------------------------------- encodings
def test_a_latin1_byte_in_a_comment_is_read_with_a_warning_naming_line_and_offset(tmp_path):
    text = "\n".join([HEADER, *good_rows(3), "# Zürich", *good_rows(6)[3:]]) + "\n"
    data = text.encode("latin-1")
    offset = data.index(b"\xfc")
    proc, src, _ = convert_cli(tmp_path, "latin1.csv", data)
    assert proc.returncode == 0, proc.stderr
    assert "6 flights written, 0 skipped" in proc.stdout
    assert f"warning: {src}:5: byte 0xFC at offset {offset} is not UTF-8" in proc.stderr
    assert "cp1252" in proc.stderr


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-8-sig", "cp1252"])
def test_utf16_bom_and_cp1252_files_convert_through_the_cli(tmp_path, encoding):
    rows = good_rows(5)
    rows[1] = rows[1].replace("N002", "N€2")  # a tail id with a euro sign (0x80 in cp1252)
    proc, _, out = convert_cli(tmp_path, "enc.csv", ("\n".join([HEADER, *rows]) + "\r\n").encode(encoding))
    assert proc.returncode == 0, proc.stderr
    assert "5 flights written, 0 skipped" in proc.stdout
    assert ("is not UTF-8" in proc.stderr) == (encoding == "cp1252")
    assert created_callsigns(out.read_text()) == [f"G{k:03d}" for k in range(5)]


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.text(alphabet=st.characters(min_codepoint=32, max_codepoint=255, blacklist_characters='",'),
               max_size=15),
       st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "cp1252", "latin-1"]))
def test_every_encoding_gives_the_same_flights(tmp_path, comment, encoding):
    try:
        data = ("\n".join([HEADER, f"# {comment}", *good_rows(4)]) + "\n").encode(encoding)
    except UnicodeEncodeError:
        return  # cp1252 lacks a few Latin-1 characters
    path = tmp_path / "e.csv"
    path.write_bytes(data)
    sched = read_schedule(path, NET)
    assert sched.errors == [] and [f.flight_id for f in sched.flights] == [f"G{k:03d}" for k in range(4)]


# ----------------------------------------------------------------------------- absurd times
@pytest.mark.parametrize("value", ["1e303", "inf", "nan", "-5", "999:00", "604801", "2030-01-09T00:00:00"])
def test_out_of_range_departure_times_are_row_errors(value):
    rows = good_rows(3)
    first = "2030-01-01T08:00:00" if value.startswith("2030") else "08:00:00"
    rows[0] = rows[0].replace("08:00:00", first)
    cells = rows[1].split(",")
    cells[5] = value
    rows[1] = ",".join(cells)
    sched = parse_schedule(io.StringIO("\n".join([HEADER, *rows]) + "\n"), NET, "t.csv")
    assert [(e.row, e.field) for e in sched.errors] == [(3, "departure_time")]
    assert [f.flight_id for f in sched.flights] == ["G000", "G002"]


def test_a_huge_time_no_longer_converts_into_a_scenario_that_crashes(tmp_path):
    rows = good_rows(2)
    rows[1] = rows[1].replace("08:01:00", "1e303")
    proc, src, out = convert_cli(tmp_path, "huge.csv", ("\n".join([HEADER, *rows]) + "\n").encode())
    assert proc.returncode == 0 and "1 flights written, 1 skipped" in proc.stdout
    assert f"{src}:3: field 'departure_time'" in proc.stderr and "horizon" in proc.stderr
    sim = Simulation(use_bluesky_navdata=False)
    assert sim.load_text(out.read_text()).errors == []


@given(st.floats(allow_nan=True, allow_infinity=True))
def test_schedule_times_are_finite_non_negative_and_within_the_horizon(x):
    try:
        t, _ = parse_schedule_time(repr(x))
    except TimeParseError:
        assert not (0 <= x <= MAX_SCHEDULE_TIME_S)
    else:
        assert math.isfinite(t) and 0 <= t <= MAX_SCHEDULE_TIME_S and t == x


# ------------------------------------------------------------------------------ streaming
def test_the_cli_writes_what_convert_returns(tmp_path):
    rows = good_rows(30)
    proc, src, out = convert_cli(tmp_path, "s.csv", ("\n".join([HEADER, *rows]) + "\n").encode())
    assert proc.returncode == 0, proc.stderr
    expected = convert(read_schedule(src, NET), NET, ConvertOptions()).text
    assert out.read_text() == expected
