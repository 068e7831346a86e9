"""BlueSky commands that are other spellings of aamsim ones: AFTER, BEFORE; and CALC.

``acid AFTER wp ADDWPT newwp [alt, spd]`` (and BEFORE) insert a waypoint
into a route next to an existing one, as ``ADDWPT acid, newwp, alt, spd,
afterwp, beforewp`` does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from aamsim.calculator import CalcError, calculate
from aamsim.errors import ArgumentError
from aamsim.stack.argtypes import RestOfLine
from aamsim.stack.commands.route_cmds import addwpt
from aamsim.stack.registry import command, raw_arguments
from aamsim.stack.tokens import split_args
from aamsim.units import looks_like_latitude

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext


def _insert(sim: CommandContext, argtext: str, where: str) -> None:
    tokens = split_args(argtext)
    if len(tokens) < 4 or tokens[2].upper() != "ADDWPT":
        raise ArgumentError(f"usage: {where} acid, wpinroute ADDWPT (wpname/lat,lon), [alt], [spd]")
    acid, anchor, rest = tokens[0], tokens[1], tokens[3:]
    npos = 2 if looks_like_latitude(rest[0]) and len(rest) > 1 else 1
    position, extra = rest[:npos], rest[npos:]
    if len(extra) > 2:
        raise ArgumentError(f'unexpected extra argument(s) "{" ".join(extra[2:])}"')
    extra += [""] * (2 - len(extra))
    after, before = (anchor, "") if where == "AFTER" else ("", anchor)
    addwpt(sim, f"{acid} {' '.join(position)},{extra[0]},{extra[1]},{after},{before}")


@command("AFTER", group="route")
@raw_arguments
def after(sim: CommandContext, argtext: RestOfLine) -> None:
    """AFTER acid, wpinroute ADDWPT (wpname/lat,lon), [alt], [spd]: add a waypoint after another one."""
    _insert(sim, argtext, "AFTER")


@command("BEFORE", group="route")
@raw_arguments
def before(sim: CommandContext, argtext: RestOfLine) -> None:
    """BEFORE acid, wpinroute ADDWPT (wpname/lat,lon), [alt], [spd]: add a waypoint before another one."""
    _insert(sim, argtext, "BEFORE")


@command("CALC", aliases=("DEBUG",), group="simulation")
@raw_arguments
def calc(sim: CommandContext, argtext: RestOfLine) -> str | None:
    """CALC expression: evaluate arithmetic (math functions, ^ for power); no effect on the simulation.

    BlueSky evaluates any Python, its internals included (``CALC bs.traf.ntraf``);
    aamsim evaluates arithmetic only and gives a warning for anything else.
    """
    try:
        return f"{argtext.strip()} = {calculate(argtext)}"
    except CalcError as exc:
        sim.report("warning", f"CALC: {exc}", sim.current_source)
        return None


COMMANDS = (after, before, calc)
