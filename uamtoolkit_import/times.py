"""Clock times in schedules and on the command line.

Schedules give times of day as ``HH:MM[:SS[.fff]]`` (hours may exceed 23
for flights after midnight), as a number of seconds since midnight (or in
the unit named in the column header), or as an ISO 8601 date-time, which is
then counted from midnight of a reference day (the day of the file's first
date-time).
"""

from __future__ import annotations

import math
import re
from datetime import date, datetime

_CLOCK = re.compile(r"^(\d{1,3}):([0-5]?\d)(?::([0-5]?\d(?:\.\d*)?))?$")
_ISO = re.compile(r"^\d{4}-\d{2}-\d{2}[T ]")

TIME_UNITS_S = {
    "s": 1.0,
    "sec": 1.0,
    "secs": 1.0,
    "seconds": 1.0,
    "min": 60.0,
    "mins": 60.0,
    "minutes": 60.0,
    "h": 3600.0,
    "hr": 3600.0,
    "hours": 3600.0,
}


MAX_SCHEDULE_TIME_S = 7 * 86400.0
"""The schedule horizon: times are at most a week after midnight of the schedule's day [s].

A scenario file's clock (``HH:MM:SS.hh``) has no upper bound, but a time far beyond any
schedule (``1e303`` s) is a typo or garbage that would only fail later, in ``aamsim run``."""


class TimeParseError(ValueError):
    """A text is not a time of day."""


def _in_horizon(seconds: float, text: str) -> float:
    if not seconds <= MAX_SCHEDULE_TIME_S:  # also NaN
        raise TimeParseError(
            f'"{text}" is beyond the schedule horizon ({MAX_SCHEDULE_TIME_S / 3600:.0f} h after midnight '
            "of the schedule's day)"
        )
    return seconds


def parse_clock(text: str) -> float:
    """``HH:MM`` or ``HH:MM:SS[.fff]`` -> seconds since midnight."""
    m = _CLOCK.match(text.strip())
    if m is None:
        raise TimeParseError(f'"{text}" is not a time (HH:MM or HH:MM:SS)')
    hours, minutes, seconds = m.groups()
    return 3600.0 * int(hours) + 60.0 * int(minutes) + (float(seconds) if seconds else 0.0)


def parse_schedule_time(text: str, unit_s: float = 1.0, reference_day: date | None = None) -> tuple[float, date | None]:
    """A schedule time -> (seconds since midnight of the reference day, reference day).

    Args:
        text: ``HH:MM[:SS]``, a number (in units of ``unit_s`` seconds) or an
            ISO 8601 date-time.
        unit_s: seconds per unit for plain numbers (from the column header).
        reference_day: day whose midnight is time 0 for ISO date-times; when
            None the date of ``text`` becomes the reference day.

    Returns:
        The time in seconds and the reference day (unchanged, or set by an
        ISO date-time).
    """
    t = text.strip()
    if not t:
        raise TimeParseError("missing value")
    if ":" in t and not _ISO.match(t):
        return _in_horizon(parse_clock(t), text), reference_day
    if _ISO.match(t):
        try:
            stamp = datetime.fromisoformat(t)
        except ValueError:
            raise TimeParseError(f'"{text}" is not an ISO 8601 date-time') from None
        day = reference_day or stamp.date()
        midnight = datetime(day.year, day.month, day.day, tzinfo=stamp.tzinfo)
        seconds = (stamp - midnight).total_seconds()
        if seconds < 0:
            raise TimeParseError(f'"{text}" is before the schedule\'s first day ({day.isoformat()})')
        return _in_horizon(seconds, text), day
    try:
        value = float(t)
    except ValueError:
        raise TimeParseError(f'"{text}" is not a time (HH:MM:SS, seconds or ISO 8601)') from None
    if not math.isfinite(value) or value < 0:
        raise TimeParseError(f'"{text}" is not a time of day (negative or not finite)')
    return _in_horizon(value * unit_s, text), reference_day


def format_clock(seconds: float, decimals: int = 0) -> str:
    """Seconds -> ``HH:MM:SS`` (``decimals`` > 0 adds fractions of a second)."""
    scale = 10**decimals
    ticks = round(seconds * scale)
    whole, frac = divmod(ticks, scale)
    hours, rem = divmod(whole, 3600)
    minutes, secs = divmod(rem, 60)
    text = f"{hours:02d}:{minutes:02d}:{secs:02d}"
    return f"{text}.{frac:0{decimals}d}" if decimals else text
