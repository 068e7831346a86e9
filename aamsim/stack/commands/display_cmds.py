"""BlueSky's display-only commands: accepted and ignored with one note each.

A headless simulator has no screen, but scenario files written for
BlueSky's GUI are full of PAN, ZOOM, SYMBOL and the like; they must not be
errors.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from aamsim.stack.argtypes import RestOfLine
from aamsim.stack.registry import command, raw_arguments

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

DISPLAY_COMMANDS = (
    "PAN", "ZOOM", "TRAIL", "TRAILS", "SWRAD", "DISP", "COLOUR", "COLOR", "COL", "SYMBOL", "LABEL",
    "FILTERALT", "SSD", "ND", "PLOT", "LEGEND", "INSEDIT", "DOC", "SCREENSHOT", "SHOWWPT", "MAP",
    "DUMPRTE", "ATCMODE", "SHOWTRAF", "FIXDT", "DTMULT", "RTF", "REALTIME", "RT", "TIME", "DATE", "MAGVAR",
)


def _ignored(name: str) -> Callable[..., Any]:
    @command(name, group="display")
    @raw_arguments
    def handler(sim: CommandContext, argtext: RestOfLine) -> None:
        sim.note_once(f"display:{name}", f"{name} ignored: aamsim is headless (display or real-time command)",
                      sim.current_source)

    handler.__doc__ = f"{name} ...: BlueSky display/real-time command, accepted and ignored headless."
    return handler


# (A command of + or = and - signs, BlueSky's console zoom keys, is read as ZOOM: see
# aamsim.stack.parser.resolve_command_form.)
COMMANDS = tuple(_ignored(name) for name in DISPLAY_COMMANDS)
