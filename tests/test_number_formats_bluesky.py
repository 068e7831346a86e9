"""aamsim's unit parsers beside BlueSky's own (``bluesky.tools.misc.txt2lat`` and friends).

Every token written in one of BlueSky's formats must give the same number in
both, and no token may give aamsim a number that BlueSky reads differently.
The hand-computed cases are in tests/test_number_formats.py.
"""

from __future__ import annotations

import contextlib
import io
import math

import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from aamsim.units import (
    FPM,
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


bluesky_misc = pytest.importorskip("bluesky.tools.misc")
bluesky_position = pytest.importorskip("bluesky.tools.position")
pytestmark = pytest.mark.bluesky


def _bluesky(fn, text):
    """BlueSky's value, or None where it raises or prints a value error and returns 0.0."""
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out):
            value = fn(text)
    except (ValueError, IndexError):
        return None
    if "value error" in out.getvalue():
        return None
    return value


def _aamsim(fn, text):
    try:
        return fn(text)
    except UnitParseError:
        return None


def _islat(text):
    try:
        return bool(bluesky_position.islat(text))
    except IndexError:  # BlueSky's islat("") and islat("-")
        return False


_digits = st.text("0123456789", min_size=1, max_size=4)
_whole = st.integers(0, 89).flatmap(lambda d: st.sampled_from([str(d), f"{d:02d}", f"{d:03d}"]))
_decimal = st.one_of(
    st.floats(min_value=0, max_value=89.999, allow_nan=False).map(repr),
    st.floats(min_value=0, max_value=89.999, allow_nan=False).map(lambda v: f"{v:.4f}"),
    st.floats(min_value=1e-20, max_value=89.0).map(lambda v: f"{v:e}"),
    st.floats(min_value=1e-20, max_value=89.0).map(lambda v: f"{v:.3E}"),
    st.builds(lambda a, b: f"{a}.{b}", _whole, _digits),
    st.builds(lambda b: f".{b}", _digits),
    st.builds(lambda a: f"{a}.", _whole),
    _whole,
)


@st.composite
def _dms(draw):
    deg = draw(st.integers(0, 89))
    fields = [draw(st.sampled_from([str(deg), f"{deg:02d}", f"{deg:03d}"]))]
    nfields = draw(st.integers(1, 3))
    if nfields > 1:
        fields.append(f"{draw(st.integers(0, 59)):02d}")
    if nfields > 2:
        fields.append(draw(st.sampled_from(["0", "00", "12", "59.9", "7.25", "30.0"])))
    marks = draw(st.sampled_from(["'''", "\u00b0'\"", "''\""]))
    text = ""
    for k, field in enumerate(fields):
        text += field + (marks[k] if k < len(fields) - 1 or draw(st.booleans()) else "")
    if len(text) and text[-1] not in "'\"\u00b0" and len(fields) == 1:
        text += "'"  # one field needs a mark to be DMS
    return text


def _signed(body, positive, negative):
    """At most one sign and one hemisphere letter, in either order, at most one negation."""
    return st.tuples(st.sampled_from(["", "+", "-"]), st.sampled_from(["", positive, negative]),
                     st.booleans()).filter(
        lambda t: (t[0] == "-") + (t[1] == negative) <= 1 and not (t[0] == "+" and t[1] == negative)
    ).map(lambda t: (t[0] + t[1] if t[2] else t[1] + t[0]) + body)


_latitudes = st.one_of(_decimal, _dms()).flatmap(lambda b: _signed(b, "N", "S"))
_longitudes = st.one_of(_decimal, _dms()).flatmap(lambda b: _signed(b, "E", "W"))


@settings(max_examples=600, deadline=None)
@given(_latitudes)
@example("N52'18'12.0\"")
@example("-3.061616997868383e-17")
def test_latitude_formats_read_as_bluesky_reads_them(text):
    expected = _bluesky(bluesky_misc.txt2lat, text)
    assert expected is not None, f"not a BlueSky format: {text!r}"
    assert looks_like_latitude(text)
    # BlueSky's islat keeps the degree sign: its position parser refuses N52\u00b018' (aamsim reads it).
    assert _islat(text) or "\u00b0" in text
    assert parse_latitude(text) == expected


def _bluesky_drops_the_exponent(text):
    """BlueSky's txt2lon removes every E once a hemisphere letter stops float(): W7.4E1 is -7.41."""
    return text.lstrip("+-")[:1].upper() in ("E", "W") and "E" in text.upper().lstrip("+-")[1:]


@settings(max_examples=600, deadline=None)
@given(_longitudes)
@example("W074'00'36")
@example("6.123233995736766e-17")
def test_longitude_formats_read_as_bluesky_reads_them(text):
    assume(not _bluesky_drops_the_exponent(text))
    expected = _bluesky(bluesky_misc.txt2lon, text)
    assert expected is not None, f"not a BlueSky format: {text!r}"
    assert parse_longitude(text) == expected


def test_longitude_with_hemisphere_and_exponent_is_read_as_written():
    # BlueSky drops every E: W7.4E1 becomes -7.41. aamsim reads the number written.
    assert bluesky_misc.txt2lon("W7.4E1") == -7.41
    assert parse_longitude("W7.4E1") == -74.0


_token_chars = st.text("0123456789.+-eENSWMT'\"\u00b0_:FL", max_size=12)  # no blanks: they end a token


@settings(max_examples=1500, deadline=None)
@given(_token_chars)
@example("e0E1")  # a lower-case hemisphere letter with an exponent: the documented exception too (BlueSky: 1.0)
def test_no_token_gives_aamsim_another_number_than_bluesky(text):
    """Where both read a token, they read the same number; aamsim reads no token BlueSky refuses,
    except the documented ones (Mach above 1, a longitude with hemisphere and exponent)."""
    text = text.strip()
    lat = _aamsim(parse_latitude, text)
    if lat is not None:
        assert _bluesky(bluesky_misc.txt2lat, text) == lat
    if looks_like_latitude(text) and "\u00b0" not in text:
        assert _islat(text)
    lon = _aamsim(parse_longitude, text)
    if lon is not None and not _bluesky_drops_the_exponent(text):
        assert _bluesky(bluesky_misc.txt2lon, text) == lon
    alt = _aamsim(parse_altitude, text)
    if alt is not None:
        assert _bluesky(bluesky_misc.txt2alt, text) == alt
    spd = _aamsim(parse_speed, text)
    if spd is not None and not (spd.is_mach and spd.value >= 1.0):
        assert _bluesky(bluesky_misc.txt2spd, text) == spd.value
    vs = _aamsim(parse_vspeed, text)
    if vs is not None:
        assert _bluesky(bluesky_misc.txt2vs, text) == vs
    tim = _aamsim(parse_time, text)
    if tim is not None:
        assert _bluesky(bluesky_misc.txt2tim, text) == tim


_altitudes = st.one_of(
    st.integers(0, 600).map(lambda fl: f"FL{fl:03d}"),
    st.integers(10, 999).map(lambda fl: f"fl{fl}"),
    st.integers(-2000, 60000).map(str),
    st.floats(min_value=-2000, max_value=60000, allow_nan=False).map(repr),
    st.floats(min_value=1, max_value=60000).map(lambda v: f"{v:e}"),
)


@settings(max_examples=300, deadline=None)
@given(_altitudes)
def test_altitude_formats(text):
    assert parse_altitude(text) == bluesky_misc.txt2alt(text)


_speeds = st.one_of(
    st.integers(0, 600).map(str),
    st.floats(min_value=0, max_value=600, allow_nan=False).map(repr),
    st.floats(min_value=1, max_value=600).map(lambda v: f"{v:E}"),
    st.integers(0, 99).map(lambda m: f"M{m:02d}"),
    st.integers(0, 999).map(lambda m: f"M.{m}"),
    st.integers(0, 999).map(lambda m: f"M0.{m}"),
    st.floats(min_value=0.1001, max_value=0.999).map(lambda v: f"{v:.3f}"),
)


@settings(max_examples=300, deadline=None)
@given(_speeds)
def test_speed_formats(text):
    speed = parse_speed(text)
    assert speed.value == bluesky_misc.txt2spd(text)
    assert speed.is_mach == ("M" in text.upper() or 0.1 < float(text) < 1.0)


_headings = st.one_of(
    st.integers(0, 359).map(lambda h: f"{h:03d}"),
    st.integers(0, 359).map(str),
    st.integers(1, 359).map(lambda h: f"{h}T"),  # BlueSky strips the zeros of 0T and fails on "T"
    st.integers(0, 359).map(lambda h: f"T{h:03d}"),
    st.floats(min_value=0, max_value=359.99, allow_nan=False).map(lambda v: f"{v:.2f}"),
    st.integers(-359, -1).map(str),
)


@settings(max_examples=300, deadline=None)
@given(_headings)
def test_heading_formats(text):
    # BlueSky keeps -90 as -90 and turns it into 270 later; aamsim normalises at once.
    assert parse_heading(text) == bluesky_misc.txt2hdg(text) % 360.0


_times = st.one_of(
    st.floats(min_value=0, max_value=86400, allow_nan=False).map(lambda v: f"{v:.2f}"),
    st.tuples(st.integers(0, 59), st.floats(min_value=0, max_value=59.99)).map(lambda t: f"{t[0]}:{t[1]:05.2f}"),
    st.tuples(st.integers(0, 99), st.integers(0, 59), st.floats(min_value=0, max_value=59.99)).map(
        lambda t: f"{t[0]:02d}:{t[1]:02d}:{t[2]:05.2f}"),
    st.floats(min_value=1, max_value=86400).map(lambda v: f"{v:e}"),
)


@settings(max_examples=300, deadline=None)
@given(_times)
def test_time_formats(text):
    assert parse_time(text) == bluesky_misc.txt2tim(text)


@given(st.floats(min_value=-1e5, max_value=1e5, allow_nan=False))
def test_vertical_speed_formats(v):
    for text in (repr(v), f"{v:e}"):
        assert parse_vspeed(text) == bluesky_misc.txt2vs(text)


def test_zero_true_heading():
    # BlueSky strips the leading zero of 0T and then fails on "T"; aamsim reads 0.
    with pytest.raises(ValueError):
        bluesky_misc.txt2hdg("0T")
    assert parse_heading("0T") == 0.0 == parse_heading("T000")


def test_finite_numbers_only():
    # BlueSky reads inf/nan as numbers; aamsim refuses them (docs/bluesky-differences.md 4.9).
    assert math.isinf(bluesky_misc.txt2alt("inf"))
    for parser in (parse_altitude, parse_latitude, parse_longitude, parse_vspeed, parse_heading):
        with pytest.raises(UnitParseError):
            parser("inf")
