"""Departure requests in a scenario: the schedule a strategic planner decides on.

A UAMToolkit-style scenario (``uam2scn``) files every flight as a block of
lines at its departure time: ``CRE`` and then ``ORIG``, ``DEST``, ``ADDWPT``,
``VNAV``, ``SPD``, ``RTA``, ``ATDIST ... DEL`` naming the callsign. Here a
**request** is a flight the scenario creates at a known time:

* a top-level ``CRE``/``CREATE`` line, or one nested in a top-level
  ``SCHEDULE time, CRE ...`` (absolute time) or ``DELAY time, CRE ...``
  (relative to the line) — BlueSky's two ways of filing a command for later;
* its **block** is that creation and every later command whose aircraft
  argument (the first, after BlueSky's ``ACID CMD`` form is resolved) is the
  callsign, directly or nested in ``SCHEDULE``/``DELAY``, each at its own
  time, until the callsign is created again (a callsign may fly twice).

Every other command is left where it is. Aircraft created at run time by
``MCRE``, ``PCALL``ed files or plugins are not requests: they fly unplanned,
as background traffic. Pure functions: nothing here touches a simulation.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from aamsim.errors import ScenarioSyntaxError
from aamsim.stack.parser import TimedCommand, parse_line, resolve_command_form
from aamsim.stack.tokens import next_arg
from aamsim.units import UnitParseError, parse_time

CREATE_COMMANDS = ("CRE", "CREATE")
LATER_COMMANDS = ("SCHEDULE", "DELAY")


@dataclass(frozen=True)
class DepartureRequest:
    """One flight of the schedule: its filed departure time and its block of commands."""

    key: str  # the callsign; "<callsign>#k" for its k-th creation (k >= 2)
    acid: str
    request_s: float  # filed departure (creation) time [s of sim time]
    commands: tuple[TimedCommand, ...]  # the block at its filed times, the creation first

    def shifted(self, delay_s: float) -> list[TimedCommand]:
        """The block, every command ``delay_s`` later (absolute times inside arguments, e.g. RTA, stay)."""
        return [TimedCommand(c.time_s + delay_s, c.command, c.source) for c in self.commands]


@dataclass(frozen=True)
class Schedule:
    """A scenario's commands split into departure requests and everything else."""

    requests: tuple[DepartureRequest, ...]  # by filed time, then file order
    other: tuple[TimedCommand, ...]  # the commands that belong to no request, unchanged


def effective_command(cmd: TimedCommand, is_command: Callable[[str], bool]) -> TimedCommand | None:
    """The command a top-level line files and when it runs: ``SCHEDULE``/``DELAY`` unwrapped.

    None for a ``SCHEDULE``/``DELAY`` line whose time or nested command cannot be
    read (the simulation reports it when it runs; it is left as is).
    """
    name = cmd.command.name
    if name not in LATER_COMMANDS:
        return cmd
    when_text, rest = next_arg(cmd.command.argtext)
    try:
        when = parse_time(when_text)
        inner = resolve_command_form(parse_line(rest, cmd.source), is_command)
    except (UnitParseError, ScenarioSyntaxError):
        return None
    due = max(when, cmd.time_s) if name == "SCHEDULE" else cmd.time_s + when
    return TimedCommand(due, inner, cmd.source)


def aircraft_argument(cmd: TimedCommand) -> str:
    """The first argument of a command, upper case (the aircraft of a flight's commands)."""
    return next_arg(cmd.command.argtext)[0].upper()


def split_schedule(commands: Sequence[TimedCommand], is_command: Callable[[str], bool]) -> Schedule:
    """Split a parsed scenario into departure requests and other commands (module docstring)."""
    staged: list[tuple[float, int, TimedCommand, TimedCommand | None]] = []
    for k, cmd in enumerate(commands):
        eff = effective_command(cmd, is_command)
        staged.append((eff.time_s if eff is not None else cmd.time_s, k, cmd, eff))
    staged.sort(key=lambda s: (s[0], s[1]))  # by the time each command takes effect, then file order
    blocks: dict[str, list[TimedCommand]] = {}  # request key -> its block
    current: dict[str, str] = {}  # callsign -> key of its latest request
    created: dict[str, int] = {}
    other: list[tuple[int, TimedCommand]] = []
    for _, k, cmd, eff in staged:
        if eff is None:
            other.append((k, cmd))
            continue
        acid = aircraft_argument(eff)
        if eff.command.name in CREATE_COMMANDS and acid:
            created[acid] = created.get(acid, 0) + 1
            key = acid if created[acid] == 1 else f"{acid}#{created[acid]}"
            current[acid] = key
            blocks[key] = [eff]
        elif acid and acid in current:
            blocks[current[acid]].append(eff)
        else:
            other.append((k, cmd))
    requests = [DepartureRequest(key, aircraft_argument(block[0]), block[0].time_s, tuple(block))
                for key, block in blocks.items()]
    requests.sort(key=lambda r: r.request_s)  # stable: file order among equal times
    other.sort(key=lambda o: o[0])
    return Schedule(tuple(requests), tuple(c for _, c in other))
