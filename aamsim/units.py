"""Unit constants and the text <-> SI conversions used at the stack boundary.

Everything inside the simulator is SI (m, m/s, s) with angles in degrees.
Aviation units appear only here, in the scenario language and in reports.
The constants are the ones BlueSky uses, so that converted values agree to
the last bit with a BlueSky run of the same scenario.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

FT = 0.3048  # m per foot
KTS = 0.514444  # m/s per knot (BlueSky's rounded value)
NM = 1852.0  # m per nautical mile
FPM = FT / 60.0  # m/s per foot per minute
G0 = 9.80665  # m/s^2
R_EARTH = 6371000.0  # m, mean radius used by the flat-earth position update


class UnitParseError(ValueError):
    """A token could not be read as the quantity it should be."""


@dataclass(frozen=True)
class Speed:
    """A commanded airspeed: either a CAS in m/s or a Mach number.

    BlueSky encodes both in one float and treats any value between 0.1 and
    2.0 as a Mach number, which turns a 3 kt drone into a Mach 1.5 one. We keep
    the kind explicit instead.
    """

    value: float
    is_mach: bool = False

    def __str__(self) -> str:
        if self.is_mach:
            return f"M{self.value:g}"
        return f"{self.value / KTS:g}"


# The longest time a scenario may name: 100 years of simulated time. Beyond it the
# clock's microseconds no longer fit a float exactly and 1e308 s overflowed it.
MAX_TIME_S = 100 * 365.25 * 86400.0
# Altitudes an aircraft can have, in feet: from below the Dead Sea's shore to 200,000 ft
# (61 km, where the atmosphere model's density is still positive). Beyond them is a typo:
# -1e6 ft was accepted, and above about 1.55e7 ft the density underflowed to zero.
MIN_ALTITUDE_FT = -2000.0
MAX_ALTITUDE_FT = 200_000.0
MAX_FLIGHT_LEVEL = 2000
# The longest callsign an aircraft may have (ICAO's are 7 characters, OpenSky's 8). Every output
# and viewer holds callsigns in fixed-width arrays: one 20,000-character id widened all of them.
MAX_CALLSIGN_CHARS = 32


def parse_altitude(text: str) -> float:
    """Read an altitude: feet, or a flight level ``FLnnn``.

    Args:
        text: e.g. ``"1500"``, ``"FL350"``, ``"-20"``.

    Returns:
        Altitude in metres.
    """
    t = text.strip().upper()
    if t.startswith("FL") and len(t) >= 4:
        digits = t[2:]
        if digits.isdigit() and len(digits) <= len(str(MAX_FLIGHT_LEVEL)) and int(digits) <= MAX_FLIGHT_LEVEL:
            return 100.0 * int(digits) * FT
        if digits.isdigit():
            raise UnitParseError(f'"{text}": flight level above FL{MAX_FLIGHT_LEVEL}')
    else:
        try:
            value = float(t)
        except ValueError:
            pass
        else:
            if math.isfinite(value):
                if not MIN_ALTITUDE_FT <= value <= MAX_ALTITUDE_FT:
                    raise UnitParseError(f'"{text}": altitude outside {MIN_ALTITUDE_FT:,.0f} .. '
                                         f'{MAX_ALTITUDE_FT:,.0f} ft')
                return value * FT
    raise UnitParseError(f'"{text}" is not an altitude (feet or FLnnn)')


def format_altitude(alt_m: float) -> str:
    """Inverse of :func:`parse_altitude` (feet, full precision)."""
    return repr(alt_m / FT)


_MACH_RE = re.compile(r"^M(0?\.\d+|\d+(\.\d*)?)$")


def parse_speed(text: str) -> Speed:
    """Read a speed the way BlueSky does: knots CAS, or Mach.

    ``M.78``, ``M0.78``, ``M78`` (read as 0.78 like BlueSky's ``M78``) and a
    bare number strictly between 0.1 and 1.0 are Mach numbers; anything else is
    knots CAS.

    Returns:
        A :class:`Speed` holding m/s CAS or a Mach number.
    """
    t = text.strip().upper()
    if t.startswith("M"):
        m = _MACH_RE.match(t)
        if not m:
            raise UnitParseError(f'"{text}" is not a speed (kts CAS or Mach)')
        body = m.group(1)
        mach = float(body)
        if "." not in body:  # M78 means Mach 0.78
            mach = float("0." + body)
        return Speed(mach, is_mach=True)
    try:
        value = float(t)
    except ValueError:
        raise UnitParseError(f'"{text}" is not a speed (kts CAS or Mach)') from None
    if not math.isfinite(value):
        raise UnitParseError(f'"{text}" is not a finite speed')
    if 0.1 < value < 1.0:
        return Speed(value, is_mach=True)
    return Speed(value * KTS, is_mach=False)


def format_speed(speed: Speed) -> str:
    """Inverse of :func:`parse_speed`."""
    if speed.is_mach:
        return "M" + repr(speed.value)
    return repr(speed.value / KTS)


def parse_vspeed(text: str) -> float:
    """Read a vertical speed in feet per minute; returns m/s."""
    try:
        value = float(text)
    except ValueError:
        raise UnitParseError(f'"{text}" is not a vertical speed (fpm)') from None
    if not math.isfinite(value):
        raise UnitParseError(f'"{text}" is not a finite vertical speed')
    return value * FPM


def parse_heading(text: str) -> float:
    """Read a heading in degrees (``090``, ``270T``, ``T270``); returns degrees in [0, 360).

    Magnetic headings (``M`` suffix) need a declination model; aamsim has
    none, so they are refused rather than silently treated as true.
    """
    t = text.strip().upper()
    if len(t) > 1 and "M" in (t[0], t[-1]):
        raise UnitParseError(f'"{text}": magnetic headings are not supported, give a true heading')
    if len(t) > 1 and "T" in (t[0], t[-1]):  # BlueSky reads 270T and T270 alike
        t = t[1:] if t[0] == "T" else t[:-1]
    try:
        value = float(t)
    except ValueError:
        raise UnitParseError(f'"{text}" is not a heading in degrees') from None
    if not math.isfinite(value):
        raise UnitParseError(f'"{text}" is not a finite heading')
    return value % 360.0


def parse_time(text: str) -> float:
    """Read a duration or clock time ``[[HH:]MM:]SS[.hh]``; returns seconds."""
    parts = text.strip().split(":")
    if not 1 <= len(parts) <= 3 or any(p.strip() == "" for p in parts[-1:]):
        raise UnitParseError(f'"{text}" is not a time ([[HH:]MM:]SS.hh)')
    try:
        seconds = float(parts[-1])
        minutes = int(parts[-2]) if len(parts) > 1 and parts[-2] else 0
        hours = int(parts[-3]) if len(parts) > 2 and parts[-3] else 0
    except ValueError:
        raise UnitParseError(f'"{text}" is not a time ([[HH:]MM:]SS.hh)') from None
    return checked_time(seconds, minutes, hours, text)


def checked_time(seconds: float, minutes: int = 0, hours: int = 0, text: str = "") -> float:
    """``hours:minutes:seconds`` in seconds, refused (UnitParseError) if negative, not finite or
    beyond :data:`MAX_TIME_S`. The whole parts are compared as integers: a 400-digit hour
    overflowed a float."""
    shown = text or f"{hours}:{minutes}:{seconds}"
    if not math.isfinite(seconds) or seconds < 0 or minutes < 0 or hours < 0:
        raise UnitParseError(f'"{shown}" is not a time: negative or not finite')
    if hours * 3600 + minutes * 60 > MAX_TIME_S or seconds > MAX_TIME_S:
        raise UnitParseError(f'"{shown}" is beyond the longest simulated time (100 years)')
    total = (seconds + 60.0 * minutes) + 3600.0 * hours  # BlueSky's order (txt2tim): the same float, bit for bit
    if total > MAX_TIME_S:
        raise UnitParseError(f'"{shown}" is beyond the longest simulated time (100 years)')
    return total


def format_time(seconds: float) -> str:
    """Seconds -> ``HH:MM:SS.hh`` (the scenario-file clock format)."""
    centis = int(round(seconds * 100))
    hours, rem = divmod(centis, 360000)
    minutes, rem = divmod(rem, 6000)
    secs, hundredths = divmod(rem, 100)
    return f"{hours:02d}:{minutes:02d}:{secs:02d}.{hundredths:02d}"


def parse_bool(text: str) -> bool:
    """ON/OFF, TRUE/FALSE, YES/NO, 1/0 (case-insensitive)."""
    t = text.strip().lower()
    if t in ("on", "true", "yes", "y", "1"):
        return True
    if t in ("off", "false", "no", "n", "0"):
        return False
    raise UnitParseError(f'"{text}" is not ON/OFF')


_DMS_MARKS = "'\"\u00b0"
_DMS_FIELD = re.compile(r"[0-9]+(\.[0-9]*)?|\.[0-9]+")  # plain decimals: BlueSky's longitude drops every E


def _dms_to_degrees(body: str, original: str, what: str) -> float:
    """``52'14'13.5`` (degrees, minutes, seconds; ``'``, ``"`` or ``\u00b0`` marks) -> degrees, unsigned.

    BlueSky's readers take every field as a magnitude and add them with divisors 1, 60 and 3600.
    A sign inside a field (BlueSky makes the whole angle negative), a fourth field (BlueSky adds
    it as 1/216000 deg) and an empty field between two others (BlueSky's latitude skips it, its
    longitude counts it as zero) have no sure meaning: refused.
    """
    for mark in _DMS_MARKS[1:]:
        body = body.replace(mark, "'")
    fields = body.split("'")
    while fields and fields[-1] == "":
        fields.pop()
    if not fields or len(fields) > 3:
        raise UnitParseError(f'"{original}" is not a {what}: expected degrees\'minutes\'seconds')
    value = 0.0
    scale = 1.0
    for field in fields:
        if not _DMS_FIELD.fullmatch(field):
            raise UnitParseError(f'"{original}" is not a {what}: bad degrees\'minutes\'seconds field "{field}"')
        value += float(field) / scale
        scale *= 60.0
    return value


def _parse_angle(text: str, positive: str, negative: str, limit: float, what: str) -> float:
    """A latitude or longitude as BlueSky's ``txt2lat``/``txt2lon`` read it, without their accidents.

    Accepted: a number (decimal or exponent notation, ``-3.06e-17``) or degrees'minutes'seconds,
    after at most one sign and at most one hemisphere letter in either order (``N52.5``,
    ``-N52``, ``W074'00'36"``); degrees'minutes'seconds may end in an E (N), as BlueSky reads
    it (``E005'00'00.00"E``), unless the angle starts with W (S). Refused where BlueSky silently returns 0 or reads a number other
    than the one written: two negations (``S-52``), signs inside the number, empty text.
    """
    t = text.strip().upper()
    negations = 0
    hemisphere = sign = False
    leading = ""  # the hemisphere letter before the number, if any
    while t and t[0] in ("+", "-", positive, negative):
        c = t[0]
        if c in "+-":
            if sign:
                raise UnitParseError(f'"{text}" is not a {what}: more than one sign')
            sign = True
        else:
            if hemisphere:
                raise UnitParseError(f'"{text}" is not a {what}: more than one hemisphere letter')
            hemisphere = True
            leading = c
        negations += c in ("-", negative)
        t = t[1:]
    plus = text.strip().startswith("+") or text.strip()[1:2] == "+"
    if negations > 1 or (plus and negations):  # BlueSky: an error, or 0.0 after a printed "value error"
        raise UnitParseError(f'"{text}" is not a {what}: contradictory signs')
    if not t or t[0] in "+-":
        raise UnitParseError(f'"{text}" is not a {what}')
    if len(t) > 2 and t[-1] == positive and t[-2] in _DMS_MARKS:
        # An E (N) after the seconds mark (``E005'00'00.00"E`` in BlueSky's corpus): BlueSky deletes every
        # E (N) wherever it stands. (A trailing W or S becomes a "-" field there, read as 0.0: refused here.)
        if leading == negative:
            raise UnitParseError(f'"{text}" is not a {what}: contradictory hemisphere letters')
        t = t[:-1]
    if any(c in t for c in _DMS_MARKS):
        value = _dms_to_degrees(t, text, what)
    else:
        if "_" in t:  # float() reads "5_2" as 52; BlueSky does too, but no one means it
            raise UnitParseError(f'"{text}" is not a {what}')
        try:
            value = float(t)
        except ValueError:
            raise UnitParseError(f'"{text}" is not a {what}') from None
    if negations:
        value = -value
    if not math.isfinite(value) or abs(value) > limit:
        raise UnitParseError(f'"{text}" is not a {what} (|value| <= {limit:g})')
    return value


def parse_latitude(text: str) -> float:
    """Decimal degrees or ``N52'14'13.5"``; returns degrees (north positive)."""
    return _parse_angle(text, "N", "S", 90.0, "latitude")


def parse_longitude(text: str) -> float:
    """Decimal degrees or ``E004'23'10"``; returns degrees (east positive)."""
    return _parse_angle(text, "E", "W", 180.0, "longitude")


def looks_like_latitude(text: str) -> bool:
    """True when the token reads as a latitude (so it pairs with the next token as lat, lon).

    BlueSky's test (``islat``): strip signs from the ends, drop the DMS marks and dots and one
    leading N/S, and see whether Python reads a number (so ``-3.06e-17`` is a latitude). Unlike
    BlueSky, a token that is not a finite number (``INF``) is not a latitude: it can be a name.
    """
    t = text.strip().upper().strip("-").strip("+").strip(",")
    for mark in ('"', "'", ".", "\u00b0"):
        t = t.replace(mark, "")
    if len(t) > 1 and t[0] in "NS":
        t = t[1:]
    try:
        return math.isfinite(float(t))
    except ValueError:
        return False
