"""Every number format of BlueSky's argument parser, read as BlueSky reads it.

The hand-computed cases pin the formats found in BlueSky's scenario corpus
(exponent-notation positions, degrees'minutes'seconds, flight levels, Mach
numbers, clock times). The property tests put aamsim's unit parsers beside
BlueSky's own (``bluesky.tools.misc.txt2lat`` and friends, from the installed
bluesky-simulator): every token written in one of BlueSky's formats must give
the same number in both, and no token may give aamsim a number that BlueSky
reads differently (tests/test_number_formats_bluesky.py). The few places where BlueSky reads a number other than the
one written are refused or read as written, and listed in
docs/bluesky-differences.md.
"""

from __future__ import annotations

import pytest

from aamsim.units import (
    FPM,
    FT,
    KTS,
    Speed,
    UnitParseError,
    looks_like_latitude,
    parse_altitude,
    parse_heading,
    parse_latitude,
    parse_longitude,
    parse_speed,
    parse_time,
    parse_vspeed,
)

# ------------------------------------------------------------------ by hand


def test_exponent_notation_positions():
    # ASAS-SUPER*.scn: CRE SUP4,SUPER,-3.061616997868383e-17,0.5,...
    assert looks_like_latitude("-3.061616997868383e-17")
    assert parse_latitude("-3.061616997868383e-17") == -3.061616997868383e-17
    assert parse_longitude("6.123233995736766e-17") == 6.123233995736766e-17
    assert parse_latitude("5.2E1") == 52.0 and parse_latitude("N5.2e1") == 52.0


def test_degrees_minutes_seconds():
    assert parse_latitude("N52'18'12.0\"") == 52 + 18 / 60 + 12 / 3600
    assert parse_latitude("S10\u00b015'00.0\"") == -(10 + 15 / 60)
    assert parse_longitude("E004'45'46.5\"") == 4 + 45 / 60 + 46.5 / 3600
    assert parse_longitude("W074'00'36") == -(74 + 36 / 3600)
    assert parse_longitude("004'30'") == 4.5  # no hemisphere letter: east
    assert parse_latitude("N52'") == 52.0
    # A sign and a hemisphere letter in either order, one negation.
    assert parse_latitude("-N52.5") == parse_latitude("N-52.5") == parse_latitude("S52.5") == -52.5
    assert parse_latitude("+N52.5") == 52.5
    # An E (N) after the seconds (Contest/amanscen.scn: POLY ... E005'00'00.00"E): BlueSky deletes every
    # E (N). A trailing W (S) becomes a "-" field there, read as 0.0 after a "value error": refused.
    assert parse_longitude("E005'00'00.00\"E") == parse_longitude("005'00'00\"E") == 5.0
    assert parse_longitude("-005'30'00\"E") == -5.5
    assert parse_latitude("N10'15'00\"N") == 10 + 15 / 60
    for bad in ("W005'00'00\"E", "005'30'00\"W", "E005'30'00\"W"):
        with pytest.raises(UnitParseError):
            parse_longitude(bad)
    with pytest.raises(UnitParseError):
        parse_latitude("N52'30'S")


@pytest.mark.parametrize("bad", [
    "S-52",        # two negations: BlueSky fails on the decimal, reads -52 in DMS
    "+S52'30",     # BlueSky returns 0.0 after printing "value error"
    "W-74",        # BlueSky returns 0.0
    "52''30",      # empty minutes: BlueSky's latitude skips the field, its longitude counts it 0
    "52'-30",      # a sign inside: BlueSky makes the whole angle negative
    "52'30'15'5",  # a fourth field
    "N", "-", "N52'x", "5_2", "INF", "NAN", "1e400", "91", "N95",
])
def test_latitudes_refused(bad):
    with pytest.raises(UnitParseError):
        parse_latitude(bad)


def test_what_pairs_with_the_next_token_as_a_latitude():
    for lat in ("40.7", "-74.0", "N40'42'00", "-3.06e-17", "1E5", "+52", "S.5"):
        assert looks_like_latitude(lat), lat
    for name in ("EHAM", "WP1", "SPY", "INF", "NAN", "N", "KL204", "EHAM/RW18C"):
        assert not looks_like_latitude(name), name


def test_altitude_speed_heading_time_formats():
    assert parse_altitude("FL350") == 35000 * FT
    assert parse_altitude("fl35") == 3500 * FT
    assert parse_altitude("1.5e3") == 1500 * FT
    assert parse_speed("2.5E2") == Speed(250 * KTS)
    assert parse_speed("M.78") == parse_speed("M0.78") == parse_speed("M78") == Speed(0.78, True)
    assert parse_speed("m085") == Speed(0.085, True)  # BlueSky's M085 too
    assert parse_heading("T270") == parse_heading("270T") == parse_heading("0270") == 270.0
    assert parse_heading("1e2") == 100.0
    assert parse_vspeed("-1.5e3") == -1500 * FPM
    assert parse_time("01:02:03.25") == 3723.25
    assert parse_time("2:3.5") == 123.5
    assert parse_time("1.5e2") == 150.0
