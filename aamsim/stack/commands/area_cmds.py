"""Shapes and areas: BOX, CIRCLE, POLY, POLYALT, LINE, POLYLINE, and the area plugin's AREA, EXP, TAXI.

BlueSky draws shapes on its radar screen, but they are also simulation
objects: the deletion area, the experiment area and geovectors refer to them
by name. See :mod:`aamsim.shapes` and :mod:`aamsim.deletion_area`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from aamsim.deletion_area import set_area, set_taxi
from aamsim.errors import ArgumentError
from aamsim.shapes import shapes_of
from aamsim.stack.argtypes import Altitude, Number, OnOff, PositionValue, RestOfLine, Text
from aamsim.stack.registry import command, raw_arguments, static_validator
from aamsim.stack.tokens import split_args
from aamsim.units import UnitParseError, parse_altitude

if TYPE_CHECKING:
    from aamsim.stack.argtypes import Position
    from aamsim.stack.context import CommandContext


def _flat(points: tuple[Position, ...]) -> tuple[float, ...]:
    return tuple(v for p in points for v in (p.lat, p.lon))


@command("BOX", group="shapes")
def box(sim: CommandContext, name: Text, corner0: PositionValue, corner1: PositionValue,
        top: Altitude | None = None, bottom: Altitude | None = None) -> None:
    """BOX name, lat, lon, lat, lon, [top, bottom]: define a box-shaped area (altitudes in ft or FL)."""
    shapes_of(sim).define(name, "BOX", _flat((corner0, corner1)), top, bottom)


@command("CIRCLE", group="shapes")
def circle(sim: CommandContext, name: Text, centre: PositionValue, radius_nm: Number,
           top: Altitude | None = None, bottom: Altitude | None = None) -> None:
    """CIRCLE name, lat, lon, radius, [top, bottom]: define a circle (radius in nm)."""
    shapes_of(sim).define(name, "CIRCLE", (centre.lat, centre.lon, radius_nm), top, bottom)


@command("POLY", aliases=("POLYGON",), group="shapes")
def poly(sim: CommandContext, name: Text, *points: PositionValue) -> None:
    """POLY name, lat, lon, lat, lon, ...: define a polygon."""
    shapes_of(sim).define(name, "POLY", _flat(points))


@command("POLYALT", group="shapes")
def polyalt(sim: CommandContext, name: Text, top: Altitude, bottom: Altitude, *points: PositionValue) -> None:
    """POLYALT name, top, bottom, lat, lon, lat, lon, ...: define a polygon between two altitudes."""
    shapes_of(sim).define(name, "POLY", _flat(points), top, bottom)


@command("LINE", group="shapes")
def line(sim: CommandContext, name: Text, start: PositionValue, end: PositionValue) -> None:
    """LINE name, lat, lon, lat, lon: define a line (no aircraft is ever inside a line)."""
    shapes_of(sim).define(name, "LINE", _flat((start, end)))


@command("POLYLINE", aliases=("POLYLINES", "LINES"), group="shapes")
def polyline(sim: CommandContext, name: Text, *points: PositionValue) -> None:
    """POLYLINE name, lat, lon, lat, lon, ...: define a line of several segments."""
    shapes_of(sim).define(name, "LINE", _flat(points))


def _area_arguments(argtext: str) -> list[float | str]:
    """BlueSky's ``[float/txt,float,float,float,alt,alt]``: altitudes become metres."""
    tokens = [t for t in split_args(argtext) if t]
    values: list[float | str] = []
    for k, token in enumerate(tokens):
        if k >= 6:
            raise ArgumentError(f'unexpected extra argument(s) "{" ".join(tokens[6:])}"')
        if k >= 4:
            try:
                values.append(parse_altitude(token))
            except UnitParseError as exc:
                raise ArgumentError(str(exc)) from None
            continue
        try:
            number = float(token)
        except ValueError:
            if k == 0:
                values.append(token.upper())
                continue
            raise ArgumentError(f'"{token}" is not a number') from None
        values.append(number)
    return values


def _check_area(argtext: str, ctx: object) -> None:
    _area_arguments(argtext)


@command("AREA", group="shapes")
@static_validator(_check_area)
@raw_arguments
def area(sim: CommandContext, argtext: RestOfLine) -> str:
    """AREA shapename/OFF or AREA lat, lon, lat, lon, [top, bottom]: delete aircraft that leave the area."""
    return set_area(sim, _area_arguments(argtext), experiment=False)


@command("EXP", group="shapes")
@static_validator(_check_area)
@raw_arguments
def experiment_area(sim: CommandContext, argtext: RestOfLine) -> str:
    """EXP shapename/OFF or EXP lat, lon, lat, lon, [top, bottom]: the experiment area (area of interest)."""
    return set_area(sim, _area_arguments(argtext), experiment=True)


@command("TAXI", group="shapes")
def taxi(sim: CommandContext, on: OnOff, alt: Altitude | None = None) -> None:
    """TAXI ON/OFF, [alt]: with OFF, aircraft descending below alt (1500 ft) are deleted."""
    set_taxi(sim, on, alt)


COMMANDS = (box, circle, poly, polyalt, line, polyline, area, experiment_area, taxi)
