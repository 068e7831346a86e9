"""The schedule CSV contract: header aliases and units, times, routes, bad rows."""

from __future__ import annotations

import io
import math
from pathlib import Path

import pytest
from uam_helpers import GOOD_ROWS, HEADER, write_csv

from uamtoolkit_import.headers import ScheduleFormatError, normalise_header
from uamtoolkit_import.netfile import nyc_network
from uamtoolkit_import.schedule import (
    callsign_for,
    parse_schedule,
    read_schedule,
    write_schedule,
)
from uamtoolkit_import.times import format_clock, parse_clock

NET = nyc_network()


def parse(text: str, name: str = "s.csv"):
    return parse_schedule(io.StringIO(text), NET, name)


def test_canonical_rows_are_read_in_contract_units():
    sched = parse("\n".join([HEADER, *GOOD_ROWS]) + "\n")
    assert sched.errors == [] and sched.rows == 3
    f1, f2, f3 = sched.flights
    assert (f1.row, f1.callsign, f1.origin, f1.destination) == (2, "F1", "DMH", "W30")
    assert f1.route == ("HUD02", "HUD03")  # the end points are dropped
    assert f2.route == ("HUD03", "HUD02")  # ... or were never there
    assert (f1.departure_s, f1.arrival_s) == (8 * 3600.0, 8 * 3600.0 + 240)
    assert (f1.cruise_speed_kts, f1.cruise_alt_ft, f1.passengers, f1.cargo_kg) == (120.0, 500.0, 2, 10.0)
    assert f3.cargo_kg == 45.5 and f3.tail_id == "N003" and f3.aircraft_type == "EVTOL4"


def test_header_aliases_order_case_and_units():
    header = "Dest,PAX,Cruise Speed [m/s],Flight,from,STD,Altitude (m),Arrival,Payload [lb],Extra column"
    row = "LGA,2,61.7333,uam-7,E34,08:02:30,152.4,08:10,100,whatever"
    sched = parse(f"{header}\n{row}\n")
    assert sched.errors == []
    f = sched.flights[0]
    assert (f.flight_id, f.callsign, f.origin, f.destination) == ("uam-7", "UAM7", "E34", "LGA")
    assert f.cruise_speed_kts == pytest.approx(120.0, abs=1e-3)
    assert f.cruise_alt_ft == pytest.approx(500.0)
    assert f.cargo_kg == pytest.approx(45.359237)
    assert f.arrival_s == 8 * 3600 + 600
    # No route column: the shortest route through the network.
    assert f.route == tuple(NET.shortest_path("E34", "LGA")[1:-1])


def test_unit_suffix_and_numeric_times():
    header = "flight_id,origin,destination,departure_time_min,arrival_time [h],cruise_speed_kts,cruise_alt_ft"
    sched = parse(f"{header}\nA1,DMH,W30,480,8.5,100,500\n")
    assert sched.errors == []
    assert (sched.flights[0].departure_s, sched.flights[0].arrival_s) == (28800.0, 30600.0)


def test_iso_datetimes_count_from_the_first_day():
    header = "flight_id,origin,destination,departure_time,arrival_time,cruise_speed,cruise_alt"
    rows = ["A1,DMH,W30,2019-06-03T23:50:00,2019-06-04T00:05:00,100,500", "A2,W30,DMH,2019-06-04 00:10:00,,100,500"]
    sched = parse("\n".join([header, *rows]) + "\n")
    assert sched.errors == []
    assert [f.departure_s for f in sched.flights] == [23 * 3600 + 3000.0, 86400.0 + 600]
    assert sched.flights[0].arrival_s == 86400.0 + 300
    assert math.isnan(sched.flights[1].arrival_s)


@pytest.mark.parametrize(
    ("header", "message"),
    [
        ("flight_id,origin,destination,departure_time,cruise_speed", "missing column(s) cruise_alt"),
        ("flight_id,origin,destination,departure_time,cruise_speed [mph],cruise_alt", "unknown unit 'mph'"),
        ("flight_id,flight,origin,destination,departure_time,cruise_speed,cruise_alt", "both give flight_id"),
    ],
)
def test_bad_headers_refuse_the_file(header: str, message: str):
    with pytest.raises(ScheduleFormatError) as exc:
        parse(header + "\n")
    assert str(exc.value).startswith("s.csv:1: ") and message in str(exc.value)


def test_empty_file_is_refused(tmp_path: Path):
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(ScheduleFormatError, match="empty"):
        read_schedule(tmp_path / "e.csv", NET)


BAD_ROWS = [
    ("B1,N1,X,XYZ,W30,08:00,08:05,,100,500,,", "origin", 'unknown vertiport "XYZ"'),
    ("B2,N1,X,DMH,W30,08:00,08:05,DMH HUD99 W30,100,500,,", "route", 'node "HUD99" is not in the network'),
    ("B3,N1,X,DMH,W30,08:10,08:00,,100,500,,", "arrival_time", "arrival 08:00:00 is not after departure 08:10:00"),
    ("B4,N1,X,DMH,W30,08:00,08:05,,abc,500,,", "cruise_speed", '"abc" is not a number'),
    ("B5,N1,X,DMH,W30,08:00,08:05,,100,,,", "cruise_alt", "missing value"),
    ("B6,N1,X,DMH,DMH,08:00,08:05,,100,500,,", "destination", "is also the origin"),
    ("B7,N1,X,DMH,W30,8 am,08:05,,100,500,,", "departure_time", '"8 am" is not a time'),
    ("B8,N1,X,DMH,W30,08:00,08:05,DMH HUD05 W30,100,500,,", "route", "no segment between DMH and HUD05"),
    ("B9,N1,X,DMH,W30,08:00,08:05,,-5,500,,", "cruise_speed", "must be positive"),
    ("B10,N1,X,DMH,W30,08:00,08:05,,100,500,two,", "passengers", "is not a whole number"),
    ("F1,N1,X,DMH,W30,08:00,08:05,,100,500,,", "flight_id", "already used on line 2"),
    ("B12,N1,X,DMH,LGA,08:00,08:05,,100,500,,-3", "cargo", "cannot be negative"),
]


@pytest.mark.parametrize(("row", "field", "message"), BAD_ROWS, ids=[r[0].split(",")[0] for r in BAD_ROWS])
def test_each_bad_row_kind_names_row_and_field(tmp_path: Path, row: str, field: str, message: str):
    path = write_csv(tmp_path / "s.csv", HEADER, [GOOD_ROWS[0], row, GOOD_ROWS[2]])
    sched = read_schedule(path, NET)
    assert [f.flight_id for f in sched.flights] == ["F1", "F3"]  # the bad row only is skipped
    assert sched.skipped_rows == 1
    err = sched.errors[0]
    assert (err.row, err.field) == (3, field)
    assert message in err.message
    assert str(err).startswith(f"{path}:3: field '{field}': ")


def test_all_errors_of_a_row_are_reported():
    sched = parse(HEADER + "\nB1,N1,X,XYZ,DMH,8:00:61,,,abc,,,\n")
    assert {e.field for e in sched.errors} == {"origin", "departure_time", "cruise_speed", "cruise_alt"}
    assert sched.skipped_rows == 1 and not sched.flights


def test_comment_and_blank_lines_are_skipped_and_rows_keep_their_line_numbers():
    sched = parse("\n".join([HEADER, "# a comment", "", GOOD_ROWS[0], "B,N,X,XYZ,W30,08:00,,,100,500,,"]) + "\n")
    assert [f.row for f in sched.flights] == [4]
    assert sched.errors[0].row == 5


def test_write_schedule_round_trips():
    sched = parse("\n".join([HEADER, *GOOD_ROWS]) + "\n")
    buf = io.StringIO()
    write_schedule(sched.flights, buf)
    again = parse(buf.getvalue())
    assert again.errors == []
    assert [
        (f.flight_id, f.route, f.departure_s, f.arrival_s, f.cruise_speed_kts, f.cruise_alt_ft, f.passengers)
        for f in again.flights
    ] == [
        (f.flight_id, f.route, f.departure_s, f.arrival_s, f.cruise_speed_kts, f.cruise_alt_ft, f.passengers)
        for f in sched.flights
    ]


def test_helpers():
    assert normalise_header(" Cruise Speed (kts) ") == ("cruise_speed", "kts")
    assert normalise_header("arrival-time") == ("arrival_time", "")
    assert callsign_for("uam_0001") == "UAM0001" and callsign_for("17") == "UAM17" and callsign_for("--") == ""
    assert parse_clock("25:01") == 90060.0 and parse_clock("08:00:01.5") == 28801.5
    assert format_clock(90061.0) == "25:01:01" and format_clock(1.25, 2) == "00:00:01.25"
