"""Unit parsers and formatters, with hand-computed values and round trips."""

from __future__ import annotations

import math

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from aamsim.units import (
    FPM,
    FT,
    KTS,
    Speed,
    UnitParseError,
    format_altitude,
    format_speed,
    format_time,
    looks_like_latitude,
    parse_altitude,
    parse_bool,
    parse_heading,
    parse_latitude,
    parse_longitude,
    parse_speed,
    parse_time,
    parse_vspeed,
)


def test_altitude_feet_and_flight_levels():
    assert parse_altitude("1500") == pytest.approx(457.2)
    assert parse_altitude("FL350") == pytest.approx(35000 * 0.3048)
    assert parse_altitude("fl050") == pytest.approx(5000 * 0.3048)
    assert parse_altitude("-20") == pytest.approx(-6.096)
    for bad in ("FLX", "abc", "", "nan", "inf"):
        with pytest.raises(UnitParseError):
            parse_altitude(bad)


def test_speed_knots_and_mach():
    assert parse_speed("250") == Speed(250 * 0.514444, False)
    assert parse_speed("M.78") == Speed(0.78, True)
    assert parse_speed("M0.78") == Speed(0.78, True)
    assert parse_speed("M78") == Speed(0.78, True)
    assert parse_speed("0.8") == Speed(0.8, True)
    # BlueSky would read 1 kt as Mach 0.51 (its 0.1..2.0 m/s window); we do not.
    assert parse_speed("1") == Speed(KTS, False)
    assert parse_speed("0") == Speed(0.0, False)
    for bad in ("M", "Mx", "fast", "nan"):
        with pytest.raises(UnitParseError):
            parse_speed(bad)


def test_vertical_speed_heading_time_bool():
    assert parse_vspeed("1500") == pytest.approx(7.62)
    assert parse_vspeed("-600") == pytest.approx(-600 * FPM)
    assert parse_heading("090") == 90.0
    assert parse_heading("450") == 90.0
    assert parse_heading("270T") == 270.0
    with pytest.raises(UnitParseError):
        parse_heading("090M")
    assert parse_time("90") == 90.0
    assert parse_time("1:30") == 90.0
    assert parse_time("01:00:00.50") == 3600.5
    assert parse_time("::5") == 5.0
    with pytest.raises(UnitParseError):
        parse_time("x:10")
    assert parse_bool("on") and parse_bool("TRUE") and not parse_bool("off")


def test_latitude_longitude_decimal_and_dms():
    assert parse_latitude("52.5") == 52.5
    assert parse_latitude("N52'30'00") == pytest.approx(52.5)
    assert parse_latitude("S10'15'00.0\"") == pytest.approx(-10.25)
    assert parse_longitude("W074'00'36") == pytest.approx(-74.01)
    assert parse_longitude("E004'23'10") == pytest.approx(4 + 23 / 60 + 10 / 3600)
    for bad in ("91", "N95", "x12"):
        with pytest.raises(UnitParseError):
            parse_latitude(bad)
    assert looks_like_latitude("40.7") and looks_like_latitude("N40'42'00") and looks_like_latitude("-74.0")
    assert not looks_like_latitude("EHAM") and not looks_like_latitude("WP1")


@given(st.floats(min_value=-2000, max_value=60000, allow_nan=False))
def test_altitude_roundtrip(alt_ft):
    alt_m = alt_ft * FT
    assert parse_altitude(format_altitude(alt_m)) == pytest.approx(alt_m, rel=1e-12, abs=1e-9)


@given(st.one_of(
    st.builds(lambda v: Speed(v * KTS, False), st.floats(min_value=1.0, max_value=600.0)),
    st.builds(lambda v: Speed(v, True), st.floats(min_value=0.05, max_value=0.99)),
))
def test_speed_roundtrip(speed):
    back = parse_speed(format_speed(speed))
    assert back.is_mach == speed.is_mach
    assert back.value == pytest.approx(speed.value, rel=1e-12)


@given(st.floats(min_value=0, max_value=10 * 86400, allow_nan=False))
@example(0.975)  # round(0.975, 2) is 0.97 but 97.5 centiseconds round to 98: both are nearest hundredths
def test_time_roundtrip(t):
    # The clock format keeps hundredths: the time read back is within half of one of t.
    assert abs(parse_time(format_time(t)) - t) <= 0.005 + 1e-9 * max(1.0, t)


@given(st.text(max_size=20))
def test_unit_parsers_only_raise_parse_errors(text):
    for parser in (parse_altitude, parse_speed, parse_vspeed, parse_heading, parse_time, parse_bool,
                   parse_latitude, parse_longitude):
        try:
            value = parser(text)
        except UnitParseError:
            continue
        if isinstance(value, float):
            assert math.isfinite(value)
