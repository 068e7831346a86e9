"""Exceptions raised inside the simulator.

They are turned into ``file:line: message`` text only at the stack boundary
(:class:`aamsim.simulation.Simulation` reports) or the bridge (error replies).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SourceRef:
    """Where a command came from: a scenario file and line, or another origin."""

    path: str = "<stack>"
    line: int = 0

    def __str__(self) -> str:
        return f"{self.path}:{self.line}" if self.line else self.path


class AamsimError(Exception):
    """Base class of all aamsim errors."""


class ScenarioSyntaxError(AamsimError):
    """A scenario line that cannot be parsed (bad time, no ``>``, unknown command)."""

    def __init__(self, message: str, source: SourceRef | None = None, column: int = 0):
        super().__init__(message)
        self.message = message
        self.source = source or SourceRef()
        self.column = column

    def __str__(self) -> str:
        return f"{self.source}: {self.message}"


class CommandError(AamsimError):
    """A command that parsed but cannot be executed (bad argument, bad state)."""

    def __init__(self, message: str):
        super().__init__(message)
        self.message = message


class ArgumentError(CommandError):
    """An argument token that does not read as its declared type."""


class UnknownAircraft(ArgumentError):
    """A callsign that names no aircraft in the simulation."""

    def __init__(self, acid: str):
        super().__init__(f"no aircraft with callsign {acid}")
        self.acid = acid
