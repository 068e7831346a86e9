"""Wind commands: WIND defines the field point by point, GETWIND reads it (``DEL WIND`` clears it)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.errors import ArgumentError
from aamsim.stack.argtypes import FLOAT, LATLON, Altitude, PositionValue, RestOfLine
from aamsim.stack.context import LiveContext
from aamsim.stack.registry import command, raw_arguments, static_validator
from aamsim.stack.tokens import split_args
from aamsim.traffic.wind import wind_from
from aamsim.units import KTS, UnitParseError, parse_altitude

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

_USAGE = "WIND lat,lon,[alt],dir,spd[,alt,dir,spd,...]"


def _number(token: str, what: str, ctx: Any) -> float:
    if not token:
        raise ArgumentError(f"wind {what} missing; usage: {_USAGE}")
    try:
        value: float = FLOAT.convert(token, ctx)
    except ArgumentError as exc:
        raise ArgumentError(f"wind {what}: {exc.message}") from None
    return value


def parse_wind(argtext: str, ctx: Any) -> tuple[float, float, list[tuple[float, float, float]] | None, float, float]:
    """``(lat, lon, profile, dir, spd)`` of a WIND command, as BlueSky reads its arguments.

    ``dir,spd`` (or ``,dir,spd`` with the altitude left empty) is one wind for
    every altitude: profile None, ``dir`` [deg] and ``spd`` [m/s] set. Triples
    ``alt,dir,spd`` give a profile of ``(alt [m], dir [deg], spd [m/s])``.
    Altitudes are feet or FLnnn, speeds knots.
    """
    pos, rest = LATLON.parse(argtext, ctx)
    data = split_args(rest)
    if len(data) == 2 or (len(data) == 3 and not data[0]):
        return pos.lat, pos.lon, None, _number(data[-2], "direction", ctx), _number(data[-1], "speed", ctx) * KTS
    if len(data) < 3 or len(data) % 3:
        raise ArgumentError(f"wind data not recognised: give dir,spd or alt,dir,spd triples; usage: {_USAGE}")
    profile = []
    for k in range(0, len(data), 3):
        if not data[k]:
            raise ArgumentError(f"wind altitude {k // 3 + 1} missing; usage: {_USAGE}")
        try:
            alt = parse_altitude(data[k])
        except UnitParseError as exc:
            raise ArgumentError(f"wind altitude: {exc}") from None
        profile.append((alt, _number(data[k + 1], "direction", ctx), _number(data[k + 2], "speed", ctx) * KTS))
    return pos.lat, pos.lon, profile, 0.0, 0.0


def _check_wind(argtext: str, ctx: Any) -> None:
    parse_wind(argtext, ctx)


@command("WIND", group="simulation")
@raw_arguments
@static_validator(_check_wind)
def wind(sim: CommandContext, argtext: RestOfLine) -> None:
    """WIND lat,lon,[alt],dir,spd[,alt,dir,spd,...]: define the wind at a point (dir it blows from, kts).

    ``dir,spd`` holds at every altitude; ``alt,dir,spd`` triples (ft or FLnnn)
    give a profile, linear between the altitudes and constant beyond them.
    Several points make a field, interpolated by inverse distance squared
    (docs/bluesky-differences.md). ``DEL WIND`` removes every point.
    """
    lat, lon, profile, direction, speed = parse_wind(argtext, LiveContext(sim))
    if profile is None:
        sim.add_wind_point(lat, lon, direction, speed)
    else:
        alts, dirs, spds = zip(*profile)
        sim.add_wind_profile(lat, lon, np.asarray(alts, dtype=float), np.asarray(dirs, dtype=float),
                             np.asarray(spds, dtype=float))


@command("GETWIND", group="simulation")
def getwind(sim: CommandContext, pos: PositionValue, alt: Altitude | None = None) -> str:
    """GETWIND lat,lon,[alt]: the wind at a position (at the ground when no altitude is given)."""
    vn, ve = sim.wind_at(pos.lat, pos.lon, 0.0 if alt is None else alt)
    direction, speed = wind_from(vn, ve)
    return f"WIND AT {pos.lat:.5f}, {pos.lon:.5f}: {round(direction):03d}/{round(speed / KTS)}"


COMMANDS = (wind, getwind)
