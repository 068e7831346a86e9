"""Simulation control: time step, scheduling, scenario files, conditions, messages."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aamsim.errors import CommandError, SourceRef
from aamsim.geo import qdrdist
from aamsim.stack.argtypes import (
    AcIndex,
    Altitude,
    Count,
    Number,
    OnOff,
    PositionValue,
    RestOfLine,
    Seconds,
    SpeedArg,
    Text,
    Word,
)
from aamsim.stack.parser import TimedCommand
from aamsim.stack.registry import command, raw_arguments, static_validator
from aamsim.stack.tokens import split_args
from aamsim.traffic.conditions import Condition
from aamsim.traffic.kernel import COND_ALT, COND_DIST, COND_SPD
from aamsim.units import NM

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext


@command("DT", group="simulation")
def dt(sim: CommandContext, first: Word = "", second: Word = "") -> str | None:
    """DT [dt] or DT ASAS dt: show or set the time step [s] (default 0.05), or the conflict-detection interval."""
    if not first:
        return f"time step {sim.dt:g} s, conflict detection every {sim.settings.cd_interval_s:g} s"
    try:
        if second:
            if first.upper() != "ASAS":
                raise CommandError(f"DT {first}: the only timer that can be set is ASAS")
            value = float(second)
            if value <= 0:
                raise CommandError("the ASAS interval must be positive")
            sim.settings.cd_interval_s = value
            return None
        sim.set_dt(float(first))
    except ValueError:
        raise CommandError(f'"{first if not second else second}" is not a time step in seconds') from None
    return None


@command("FF", aliases=("FWD",), group="simulation")
def ff(sim: CommandContext, duration: Seconds | None = None) -> None:
    """FF [time]: fast-forward. aamsim always runs as fast as it can, so this changes nothing."""
    sim.note_once("FF", "FF has no effect: aamsim always runs as fast as possible", sim.current_source)


@command("HOLD", aliases=("PAUSE",), group="simulation")
def hold(sim: CommandContext) -> None:
    """HOLD: pause the simulation (a server or environment resumes it with OP)."""
    sim.state = sim.STATE_HOLD


@command("OP", aliases=("RUN", "START", "CONTINUE"), group="simulation")
def op(sim: CommandContext) -> None:
    """OP: run (or resume after HOLD)."""
    sim.state = sim.STATE_OP


@command("RESET", group="simulation")
def reset(sim: CommandContext) -> None:
    """RESET: delete all traffic, clear pending commands and set the clock to 0."""
    sim.reset()


@command("IC", aliases=("LOAD", "OPEN"), group="simulation")
def ic(sim: CommandContext, filename: RestOfLine) -> None:
    """IC filename: reset, then load a scenario file (``IC IC`` reloads the current one)."""
    name = filename.strip()
    if not name:
        raise CommandError("IC needs a scenario file name")
    if name.upper() == "IC":
        if sim.files.path is None:
            raise CommandError("IC IC: no scenario was loaded before")
        path = sim.files.path
    else:
        found = sim.find_file(name)
        if found is None:
            raise CommandError(f"scenario file not found: {name}")
        path = found
    enter_file(sim, path, "IC")
    text = _read_scenario(path, "IC")
    sim.reset()
    sim.files.name = path.stem
    sim.files.path = path
    sim.files.text = text
    sim.load_scenario(path, text=sim.files.text)


MAX_CALL_DEPTH = 16  # files PCALL/IC may nest; deeper is refused as a runaway
# Commands PCALL may queue between two resets. Ten files each PCALLing the next ten times expand
# tenfold per level (10^10 lines at ten levels); the New York day, 4,051 flights, is 41,000
# commands, so this is the day PCALLed 24 times.
MAX_PCALL_COMMANDS = 1_000_000
# Files PCALL may load between two resets: each load costs about a millisecond, so a fan-out is
# refused after some 10 s; a scenario that PCALLs a template file for every flight of the New York
# day loads 4,051.
MAX_PCALL_FILES = 10_000


def _file_key(name: str | Path) -> str:
    try:
        return str(Path(name).resolve())
    except (OSError, RuntimeError, ValueError):
        return str(name)


def enter_file(sim: CommandContext, target: Path, verb: str) -> None:
    """Record that the file of the command being run loads ``target``; refuse a cycle or a runaway.

    A file that PCALLs itself (or files that PCALL or IC each other) would load
    without end at the same simulated time; the error names the chain of files.
    """
    source = sim.current_source
    caller = _file_key(source.path) if source is not None and source.path and not source.path.startswith("<") \
        else None
    chain = (*sim.files.call_chains.get(caller, ()), caller) if caller else ()
    key = _file_key(target)

    def shown() -> str:
        return " -> ".join(Path(c).name for c in (*chain, key))

    if key in chain:
        raise CommandError(f"{verb} {target.name}: the files call each other in a cycle ({shown()})")
    if len(chain) >= MAX_CALL_DEPTH:
        raise CommandError(f"{verb} {target.name}: files nested more than {MAX_CALL_DEPTH} deep ({shown()})")
    sim.files.call_chains[key] = chain


def _read_scenario(path: Path, verb: str) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise CommandError(f"{verb}: cannot read {path.name}: {exc.strerror or exc}") from None


def check_pcall(argtext: str, ctx: Any) -> None:
    """Static check of PCALL (``--strict``): the file must exist."""
    tokens = [t for t in split_args(argtext) if t != ""]
    if not tokens:
        raise CommandError("PCALL needs a scenario file name")
    finder = getattr(ctx, "find_file", None)
    if finder is None:
        return
    if finder(tokens[0]) is None and not (len(tokens) > 1 and finder(tokens[1]) is not None):
        raise CommandError(f"PCALL: file not found: {tokens[0]}")


@command("PCALL", aliases=("CALL",), group="simulation")
@raw_arguments
@static_validator(check_pcall)
def pcall(sim: CommandContext, argtext: RestOfLine) -> None:
    """PCALL filename, [REL/ABS], [args...]: merge another scenario file into this one.

    Times are relative to now (REL, the default) or absolute (ABS); ``%0``,
    ``%1``, ... in the file are replaced by the arguments.
    """
    tokens = [t for t in split_args(argtext) if t != ""]
    if not tokens:
        raise CommandError("PCALL needs a scenario file name")
    files = sim.files
    if files.pcall_commands >= MAX_PCALL_COMMANDS or files.pcall_files >= MAX_PCALL_FILES:
        _refuse_over_budget(sim, tokens[0])
        return
    if len(tokens) > 1 and tokens[0].upper() in sim.view:
        # PCALL acid file args: the callsign becomes %0.
        tokens = [tokens[1], tokens[0].upper(), *tokens[2:]]
    name, args = tokens[0], tokens[1:]
    relative = True
    if args and args[0].upper() in ("REL", "ABS"):
        relative = args[0].upper() == "REL"
        args = args[1:]
    path = sim.find_file(name)
    if path is None:
        raise CommandError(f"PCALL: file not found: {name}")
    enter_file(sim, path, "PCALL")
    offset = sim.simt if relative else 0.0
    parsed = sim.parse(_read_scenario(path, "PCALL"), str(path), time_offset_s=offset, substitutions=args)
    if files.pcall_commands + len(parsed.commands) > MAX_PCALL_COMMANDS:
        files.pcall_commands = MAX_PCALL_COMMANDS  # spent: later PCALLs are refused before any file is read
        _refuse_over_budget(sim, name)
        return
    files.pcall_commands += len(parsed.commands)
    files.pcall_files += 1
    for err in parsed.errors:
        sim.report("error", err.message, err.source)
    for cmd in parsed.commands:
        # Commands whose time has passed run now, in file order.
        sim.queue.push(cmd if cmd.time_s >= sim.simt else TimedCommand(sim.simt, cmd.command, cmd.source))


def _refuse_over_budget(sim: CommandContext, name: str) -> None:
    """Refuse a PCALL over the budget: an error for the first ten, then a note at every power of ten.

    A fan-out queues up to the whole budget of PCALLs before it is spent; one error each would be
    a million messages.
    """
    files = sim.files
    files.pcall_refused += 1
    count = files.pcall_refused
    spent = (f"PCALL has loaded {MAX_PCALL_FILES:,} files" if files.pcall_files >= MAX_PCALL_FILES else
             f"PCALL has queued {MAX_PCALL_COMMANDS:,} commands")
    if count <= 10:
        raise CommandError(f"{name}: refused, {spent} since the scenario started (files that PCALL each other "
                           "many times?)")
    if math.log10(count).is_integer():
        sim.report("note", f"{count:,} PCALLs refused so far: {spent} since the scenario started",
                   sim.current_source)


@command("SCHEDULE", group="simulation", nested=True)
def schedule(sim: CommandContext, time_s: Seconds, text: RestOfLine) -> None:
    """SCHEDULE time, command: run a command at an absolute sim time ([[HH:]MM:]SS)."""
    if not text:
        raise CommandError("SCHEDULE needs a command")
    sim.schedule(max(time_s, sim.simt), text, sim.current_source)


@command("DELAY", group="simulation", nested=True)
def delay(sim: CommandContext, time_s: Seconds, text: RestOfLine) -> None:
    """DELAY time, command: run a command after a delay ([[HH:]MM:]SS)."""
    if not text:
        raise CommandError("DELAY needs a command")
    sim.schedule(sim.simt + time_s, text, sim.current_source)


@command("ECHO", aliases=("PRINT",), group="simulation")
def echo(sim: CommandContext, text: RestOfLine = "") -> str:
    """ECHO text: print a message."""
    return text or " "


@command("SEED", group="simulation")
def seed(sim: CommandContext, value: Count) -> None:
    """SEED value: seed the random generator (MCRE and every seeded model)."""
    if value < 0:
        raise CommandError(f"SEED must be a whole number from 0, not {value}")
    sim.reseed(value)


@command("SCEN", aliases=("SCENARIO",), group="simulation")
def scen(sim: CommandContext, name: RestOfLine) -> None:
    """SCEN name: name the scenario."""
    sim.files.name = name.strip() or sim.files.name


@command("QUIT", aliases=("EXIT", "STOP", "CLOSE", "END"), group="simulation")
def quit_(sim: CommandContext) -> None:
    """QUIT: end the run now."""
    sim.queue.clear()
    sim.conditions.clear()
    sim.quit_requested = True


@command("DEFWPT", group="route")
def defwpt(sim: CommandContext, name: Text, pos: PositionValue, wptype: Text = "") -> None:
    """DEFWPT name, lat, lon, [type]: define a named waypoint for this run (type DEL deletes it)."""
    if wptype in ("DEL", "DELETE"):
        if not sim.navdb.delete(name):
            raise CommandError(f"no user waypoint {name}")
        return
    sim.navdb.define(name, pos.lat, pos.lon)


@command("ATALT", group="conditional", nested=True)
def atalt(sim: CommandContext, acid: AcIndex, altitude: Altitude, text: RestOfLine) -> None:
    """ATALT acid, alt, command: run a command when the aircraft crosses an altitude."""
    if not text:
        raise CommandError("ATALT needs a command")
    actual = float(sim.view.alt[acid])
    sim.conditions.add(Condition(sim.view.callsign(acid), COND_ALT, altitude, altitude - actual, text,
                                 sim.current_source or SourceRef()))


@command("ATSPD", group="conditional", nested=True)
def atspd(sim: CommandContext, acid: AcIndex, speed: SpeedArg, text: RestOfLine) -> None:
    """ATSPD acid, spd, command: run a command when the aircraft's CAS crosses a speed."""
    if not text:
        raise CommandError("ATSPD needs a command")
    if speed.is_mach:
        raise CommandError("ATSPD takes a CAS in kts, not a Mach number")
    actual = float(sim.view.cas[acid])
    sim.conditions.add(Condition(sim.view.callsign(acid), COND_SPD, speed.value, speed.value - actual, text,
                                 sim.current_source or SourceRef()))


@command("ATDIST", group="conditional", nested=True)
def atdist(sim: CommandContext, acid: AcIndex, pos: PositionValue, dist_nm: Number, text: RestOfLine) -> None:
    """ATDIST acid, lat, lon, dist, command: run a command when the aircraft comes within dist [NM] of a position."""
    if not text:
        raise CommandError("ATDIST needs a command")
    if dist_nm < 0 or not math.isfinite(dist_nm):
        raise CommandError(f"ATDIST distance must be positive, not {dist_nm:g}")
    target = dist_nm * NM
    _, actual = qdrdist(sim.view.lat[acid], sim.view.lon[acid], pos.lat, pos.lon)
    sim.conditions.add(Condition(sim.view.callsign(acid), COND_DIST, target, target - actual, text,
                                 sim.current_source or SourceRef(), pos.lat, pos.lon))


@command("AUTODELETE", group="simulation")
def autodelete(sim: CommandContext, on: OnOff | None = None) -> str | None:
    """AUTODELETE [ON/OFF]: aircraft delete themselves on passing the last waypoint of their route (aamsim extension)."""
    if on is None:
        return f"AUTODELETE is {'ON' if sim.settings.delete_on_arrival else 'OFF'}"
    sim.settings.delete_on_arrival = on
    return None


@command("ARRIVALRADIUS", group="simulation")
def arrivalradius(sim: CommandContext, radius_nm: Number | None = None) -> str | None:
    """ARRIVALRADIUS [nm]: a deleted flight counts as arrived within this distance of its destination (default 0.1)."""
    if radius_nm is None:
        return f"arrival radius {sim.settings.arrival_radius_m / NM:g} NM"
    if radius_nm < 0:
        raise CommandError("the arrival radius cannot be negative")
    sim.settings.arrival_radius_m = radius_nm * NM
    return None


@command("HELP", aliases=("?",), group="simulation")
def help_(sim: CommandContext, name: Text = "") -> str:
    """HELP [command]: list the commands, or show one command's usage and help."""
    if not name:
        return "Commands: " + ", ".join(spec.name for spec in sim.commands.specs())
    spec = sim.commands.get(name)
    if spec is None:
        raise CommandError(f"unknown command {name}")
    return f"{spec.usage}\n{spec.help}"


COMMANDS = (
    dt,
    ff,
    hold,
    op,
    reset,
    ic,
    pcall,
    schedule,
    delay,
    echo,
    seed,
    scen,
    quit_,
    defwpt,
    atalt,
    atspd,
    atdist,
    autodelete,
    arrivalradius,
    help_,
)
