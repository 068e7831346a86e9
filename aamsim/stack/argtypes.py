"""Argument types of the scenario language, with BlueSky's units and formats.

Each type reads its value from the front of the remaining argument text and
returns ``(value, rest)``. Types that need the simulation (callsigns, named
waypoints) ask a :class:`ParseContext`; the live simulation and the static
``--strict`` validator each provide one.

Command handlers declare their arguments with ``typing.Annotated``, e.g.
``alt: Altitude`` where ``Altitude = Annotated[float, ALT]``: the hint is the
real Python type, the metadata is the parser.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, Protocol

from aamsim.errors import ArgumentError
from aamsim.stack.tokens import next_arg
from aamsim.units import (
    Speed,
    UnitParseError,
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


@dataclass(frozen=True)
class Position:
    """A resolved position argument: where it is and what it was called."""

    lat: float
    lon: float
    name: str = ""
    kind: str = "latlon"  # latlon | waypoint | aircraft | runway
    heading: float | None = None  # a runway's bearing [deg]: CRE's default heading there, as in BlueSky


class ParseContext(Protocol):
    """What argument parsers may ask of their surroundings."""

    def aircraft_index(self, acid: str) -> int:
        """Index of the aircraft; raises UnknownAircraft."""
        ...

    def named_position(self, name: str) -> Position | None:
        """A named waypoint, navaid, airport or aircraft position, or None."""
        ...

    def route_has_waypoint(self, acidx: int, name: str) -> bool:
        """Whether the aircraft's route holds a waypoint of that name."""
        ...

    def note_reference(self, lat: float, lon: float) -> None:
        """Remember the last position read (nearest-match for named waypoints)."""
        ...

    last_acidx: int


class ArgType:
    """Base argument type: one token, returned as typed."""

    name = "word"

    def parse(self, text: str, ctx: ParseContext) -> tuple[Any, str]:
        token, rest = next_arg(text)
        return self.convert(token, ctx), rest

    def convert(self, token: str, ctx: ParseContext) -> Any:
        return token

    def __repr__(self) -> str:
        return self.name


class _UnitType(ArgType):
    """A token read by one of the unit parsers of :mod:`aamsim.units`."""

    def __init__(self, name: str, reader: Any):
        self.name = name
        self._reader = reader

    def convert(self, token: str, ctx: ParseContext) -> Any:
        try:
            return self._reader(token)
        except UnitParseError as exc:
            raise ArgumentError(str(exc)) from None


class TextArg(ArgType):
    name = "txt"

    def convert(self, token: str, ctx: ParseContext) -> str:
        return token.upper()


class StringArg(ArgType):
    """The whole rest of the line, as typed (ECHO text, stacked commands)."""

    name = "string"

    def parse(self, text: str, ctx: ParseContext) -> tuple[str, str]:
        return text.strip(), ""


class FloatArg(ArgType):
    name = "float"

    def convert(self, token: str, ctx: ParseContext) -> float:
        try:
            value = float(token)
        except ValueError:
            raise ArgumentError(f'"{token}" is not a number') from None
        if value != value or value in (float("inf"), float("-inf")):
            raise ArgumentError(f'"{token}" is not a finite number')
        return value


class IntArg(ArgType):
    name = "int"

    def convert(self, token: str, ctx: ParseContext) -> int:
        try:
            return int(token)
        except ValueError:
            raise ArgumentError(f'"{token}" is not a whole number') from None


class AcidArg(ArgType):
    """An existing aircraft, given by callsign; the value is its traffic index."""

    name = "acid"

    def convert(self, token: str, ctx: ParseContext) -> int:
        idx = ctx.aircraft_index(token.upper())
        ctx.last_acidx = idx
        return idx


class PositionArg(ArgType):
    """lat,lon (decimal or degrees'minutes'seconds), a named waypoint, or a callsign."""

    name = "latlon"

    def parse(self, text: str, ctx: ParseContext) -> tuple[Position, str]:
        token, rest = next_arg(text)
        if not token:
            raise ArgumentError("missing position")
        if looks_like_latitude(token):
            lon_token, rest = next_arg(rest)
            if not lon_token:
                raise ArgumentError(f'latitude "{token}" needs a longitude after it')
            try:
                pos = Position(parse_latitude(token), parse_longitude(lon_token))
            except UnitParseError as exc:
                raise ArgumentError(str(exc)) from None
            ctx.note_reference(pos.lat, pos.lon)
            return pos, rest
        name = token.upper()
        following, after = next_arg(rest)
        if following[:2].upper() == "RW" and getattr(ctx, "is_airport", _never)(name):
            name, rest = f"{name}/{following.upper()}", after  # BlueSky's "EHAM RW18C" is EHAM/RW18C
        found = ctx.named_position(name)
        if found is None:
            raise ArgumentError(f'"{name}" is not a position, known waypoint, runway or callsign')
        ctx.note_reference(found.lat, found.lon)
        return found, rest


def _never(name: str) -> bool:
    return False


class WaypointInRouteArg(ArgType):
    """The name of a waypoint in the route of the aircraft named before it (or ``*``)."""

    name = "wpinroute"

    def convert(self, token: str, ctx: ParseContext) -> str:
        name = token.upper()
        if name == "*" or ctx.route_has_waypoint(ctx.last_acidx, name):
            return name
        raise ArgumentError(f"waypoint {name} is not in the route")


ALT = _UnitType("alt", parse_altitude)
SPD = _UnitType("spd", parse_speed)
VSPD = _UnitType("vspd", parse_vspeed)
HDG = _UnitType("hdg", parse_heading)
TIME = _UnitType("time", parse_time)
ONOFF = _UnitType("onoff", parse_bool)
TXT = TextArg()
WORD = ArgType()
STRING = StringArg()
FLOAT = FloatArg()
INT = IntArg()
ACID = AcidArg()
LATLON = PositionArg()
WPINROUTE = WaypointInRouteArg()

# Handler annotations: the real Python type, with the parser as metadata.
AcIndex = Annotated[int, ACID]
Altitude = Annotated[float, ALT]
SpeedArg = Annotated[Speed, SPD]
VSpeed = Annotated[float, VSPD]
Heading = Annotated[float, HDG]
Seconds = Annotated[float, TIME]
OnOff = Annotated[bool, ONOFF]
Text = Annotated[str, TXT]
Word = Annotated[str, WORD]
RestOfLine = Annotated[str, STRING]
Number = Annotated[float, FLOAT]
Count = Annotated[int, INT]
PositionValue = Annotated[Position, LATLON]
RouteWaypoint = Annotated[str, WPINROUTE]
