"""Flight-plan commands: ADDWPT, DEST, ORIG, DELWPT, DIRECT, LNAV, VNAV, AT, RTA."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from aamsim.errors import ArgumentError, CommandError
from aamsim.stack.argtypes import (
    ACID,
    ALT,
    FLOAT,
    LATLON,
    SPD,
    WPINROUTE,
    AcIndex,
    OnOff,
    Position,
    PositionValue,
    RestOfLine,
    RouteWaypoint,
    Seconds,
    SpeedArg,
)
from aamsim.stack.context import LiveContext
from aamsim.stack.registry import command, raw_arguments, static_validator
from aamsim.stack.tokens import next_arg, split_args
from aamsim.traffic.route import Route, Waypoint, WaypointKind
from aamsim.units import FT, KTS, NM, UnitParseError, parse_altitude, parse_speed

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

_UNSUPPORTED_MODES = {"TAKEOFF"}
_WAYPOINT_MODES = ("FLYBY", "FLYOVER", "FLYTURN")
# ADDWPT's turn value words, the value's unit, and the TurnSpec value they set.
_TURN_WORDS = {
    "TURNRAD": ("radius", NM), "TURNRADIUS": ("radius", NM),
    "TURNSPD": ("speed", KTS), "TURNSPEED": ("speed", KTS),
    "TURNBANK": ("bank", 1.0), "TURNPHI": ("bank", 1.0),
    "TURNHDG": ("rate", 1.0), "TURNHDGR": ("rate", 1.0), "TURNHDGRATE": ("rate", 1.0),
}


def parse_turn_value(word: str, token: str) -> tuple[str, float]:
    """``(name, value)`` of ``TURNRAD nm`` / ``TURNSPD kts`` / ``TURNBANK deg`` / ``TURNHDG deg/s`` (``OFF``: NaN).

    A bank angle is limited to 0..90 deg, as in BlueSky.
    """
    name, unit = _TURN_WORDS[word]
    if token.upper() == "OFF":
        return name, math.nan
    try:
        value: float = FLOAT.convert(token, None)  # type: ignore[arg-type]  # a plain number needs no context
    except ArgumentError as exc:
        raise ArgumentError(f"{word} needs a number or OFF: {exc.message}") from None
    if name == "bank":
        value = max(0.0, min(value, 90.0))
    return name, value * unit


def waypoint_mode(argtext: str) -> tuple[str, str] | None:
    """``(word, value)`` when ADDWPT's arguments after the callsign set a mode instead of adding a waypoint."""
    first, rest = next_arg(argtext)
    word = first.upper().replace("-", "")
    tokens = [t for t in split_args(rest)]
    if word in _WAYPOINT_MODES and not any(tokens):
        return word, ""
    if word in _TURN_WORDS:
        if len([t for t in tokens if t]) != 1 or not tokens[0]:
            raise ArgumentError(f"{word} needs one value, e.g. ADDWPT acid {word} 0.5")
        return word, tokens[0]
    return None


def apply_waypoint_mode(route: Route, word: str, value: str) -> None:
    """FLYBY / FLYOVER / FLYTURN, or a turn value (which switches FLYTURN on), for the waypoints added next."""
    if word in _WAYPOINT_MODES:
        route.set_mode(word)
    else:
        route.set_turn_value(*parse_turn_value(word, value))


def add_waypoint(
    sim: CommandContext,
    i: int,
    name: str,
    kind: WaypointKind,
    lat: float,
    lon: float,
    alt: float = math.nan,
    spd: float = math.nan,
    spd_mach: bool = False,
    after: str = "",
    before: str = "",
) -> int:
    """Insert a waypoint in aircraft ``i``'s route the way BlueSky's FMS does.

    ORIG goes first and DEST last (replacing an earlier one); other
    waypoints go after ``after`` / before ``before`` when given, else just
    before the destination. The active waypoint is then re-activated, which
    also switches LNAV on. Returns the new waypoint's index.
    """
    view = sim.view
    route = sim.edit_route(i)
    lat = (lat + 90.0) % 180.0 - 90.0 if abs(lat) > 90.0 else lat
    lon = (lon + 180.0) % 360.0 - 180.0
    if kind in (WaypointKind.ORIG, WaypointKind.DEST):
        if kind is WaypointKind.DEST and math.isnan(alt):
            alt = 0.0
        flyby, turn = route.new_waypoint_turn()
        wp = Waypoint(name, kind, lat, lon, alt, spd, spd_mach, flyby, turn)
        slot = 0 if kind is WaypointKind.ORIG else len(route) - 1
        if len(route) and route.waypoints[slot].kind is kind:
            route.waypoints[slot] = wp
        elif kind is WaypointKind.ORIG:
            route.insert(0, wp)
            if route.iactwp >= 0:
                route.iactwp += 1
        else:
            route.insert(len(route), wp)
            if route.iactwp < 0 and len(route) == 1:
                route.iactwp = 0
        index = 0 if kind is WaypointKind.ORIG else len(route) - 1
    else:
        digits = 3 if kind is WaypointKind.LATLON else 2
        wpname = route.unique_name(name, digits, {view.callsign(i)})
        flyby, turn = route.new_waypoint_turn()
        wp = Waypoint(wpname, kind, lat, lon, alt, spd, spd_mach, flyby, turn)
        if after and route.find(after) >= 0:
            index = route.find(after) + 1
            route.insert(index, wp)
            if route.iactwp >= index:
                route.iactwp += 1
        elif before and route.find(before) >= 0:
            index = route.find(before)
            route.insert(index, wp)
        else:
            index = len(route) - 1 if route.has_dest else len(route)
            route.insert(index, wp)
    route.iactwp = max(route.iactwp, 0)
    if 0 <= route.iactwp < len(route):
        sim.activate_waypoint(i, route.iactwp)  # plans the route (Route.plan) before it reads the plan
    else:
        route.plan()
    return index


def _position_name(pos: Position, text: str) -> str:
    return pos.name if pos.name else text


def check_addwpt(argtext: str, ctx: Any) -> None:
    """Static check of ADDWPT arguments (``--strict``)."""
    _, rest = ACID.parse(argtext, ctx)
    mode_value = waypoint_mode(rest)
    if mode_value is not None:
        if mode_value[0] in _TURN_WORDS:
            parse_turn_value(*mode_value)
        return
    mode = next_arg(rest)[0].upper().replace("-", "")
    if mode in _UNSUPPORTED_MODES:
        raise CommandError(f"{mode} is not supported by aamsim (see docs/bluesky-differences.md)")
    try:
        _, rest = LATLON.parse(rest, ctx)
    except ArgumentError as exc:
        raise ArgumentError(f"waypoint: {exc.message}") from None
    token, rest = next_arg(rest)
    if token:
        ALT.convert(token, ctx)
    token, rest = next_arg(rest)
    if token:
        SPD.convert(token, ctx)
    _, rest = next_arg(rest)
    _, rest = next_arg(rest)
    if rest.strip():
        raise ArgumentError(f'unexpected extra argument(s) "{rest.strip()}"')


@command("ADDWPT", group="route")
@raw_arguments
@static_validator(check_addwpt)
def addwpt(sim: CommandContext, argtext: RestOfLine) -> None:
    """ADDWPT acid, (wpname/lat,lon), [alt, spd, afterwp, beforewp]: add a waypoint to a route.

    Alt (ft/FLnnn) and speed (kts/Mach) are constraints at the waypoint,
    obeyed with VNAV on. ``ADDWPT acid FLYBY`` / ``FLYOVER`` / ``FLYTURN`` sets
    how the waypoints added next are flown; ``ADDWPT acid TURNSPD kts`` /
    ``TURNRAD nm`` / ``TURNBANK deg`` / ``TURNHDG deg/s`` (or ``OFF``) gives
    their turn (the last two given hold) and switches FLYTURN on. With VNAV
    on, the aircraft slows to a fly-turn's speed before it. The first
    waypoint switches LNAV on.
    """
    ctx = LiveContext(sim)
    i, rest = ACID.parse(argtext, ctx)
    view = sim.view
    route = sim.edit_route(i)
    mode_value = waypoint_mode(rest)
    if mode_value is not None:
        apply_waypoint_mode(route, *mode_value)
        return
    mode = next_arg(rest)[0].upper().replace("-", "")
    if mode in _UNSUPPORTED_MODES:
        raise CommandError(f"{mode} is not supported by aamsim (see docs/bluesky-differences.md)")
    # Named waypoints are looked up nearest the route's last point (or the aircraft).
    if len(route):
        ref = route.waypoints[-2] if route.has_dest and len(route) > 1 else route.waypoints[-1]
        ctx.note_reference(ref.lat, ref.lon)
    try:
        pos, rest = LATLON.parse(rest, ctx)
    except ArgumentError as exc:
        raise ArgumentError(f"waypoint: {exc.message}") from None
    alt = math.nan
    spd = math.nan
    spd_mach = False
    token, rest = next_arg(rest)
    if token:
        alt = ALT.convert(token, ctx)
    token, rest = next_arg(rest)
    if token:
        speed = SPD.convert(token, ctx)
        spd, spd_mach = speed.value, speed.is_mach
    ctx.last_acidx = i
    after, rest = next_arg(rest)
    before, rest = next_arg(rest)
    if after:
        after = WPINROUTE.convert(after, ctx)
    if before:
        before = WPINROUTE.convert(before, ctx)
    if rest.strip():
        raise ArgumentError(f'unexpected extra argument(s) "{rest.strip()}"')
    if pos.kind == "latlon":
        name, kind = view.callsign(i), WaypointKind.LATLON
    else:
        name, kind = pos.name, WaypointKind.NAV
    add_waypoint(sim, i, name, kind, pos.lat, pos.lon, alt, spd, spd_mach, after, before)
    # The first real waypoint becomes the active one.
    real = [w for w in route.waypoints if w.kind not in (WaypointKind.ORIG, WaypointKind.DEST)]
    if len(real) == 1:
        sim.activate_waypoint(i, 1 if route.has_orig else 0)


@command("DEST", group="route")
def dest(sim: CommandContext, acid: AcIndex, pos: PositionValue | None = None, spd: SpeedArg | None = None) -> str | None:
    """DEST acid, [wpt/lat,lon, spd]: set the destination (the route's last waypoint, at altitude 0).

    When it is the only waypoint (besides an origin) it becomes active and
    LNAV and VNAV switch on.
    """
    view = sim.view
    record = sim.flight_record(acid)
    if pos is None:
        return f"DEST {view.callsign(acid)}: {record.destination or '-'}"
    name = pos.name or f"{pos.lat:.6f},{pos.lon:.6f}"
    route = sim.edit_route(acid)
    index = add_waypoint(
        sim, acid, name, WaypointKind.DEST, pos.lat, pos.lon, 0.0,
        spd.value if spd else math.nan, spd.is_mach if spd else False,
    )
    record.destination = name
    record.dest_lat, record.dest_lon = pos.lat, pos.lon
    if index == 0 or (record.origin and len(route) == 2):
        sim.set_navigation(acid, lnav=True, vnav=True)
        sim.direct_to(acid, index)
    return None


@command("ORIG", group="route")
def orig(sim: CommandContext, acid: AcIndex, pos: PositionValue | None = None) -> str | None:
    """ORIG acid, [wpt/lat,lon]: set the origin (inserted first in the route, as in BlueSky)."""
    view = sim.view
    record = sim.flight_record(acid)
    if pos is None:
        return f"ORIG {view.callsign(acid)}: {record.origin or '-'}"
    name = pos.name or f"{pos.lat:.6f},{pos.lon:.6f}"
    add_waypoint(sim, acid, name, WaypointKind.ORIG, pos.lat, pos.lon, math.nan, float(view.cas[acid]))
    record.origin = name
    return None


@command("DELWPT", aliases=("DELWP",), group="route")
def delwpt(sim: CommandContext, acid: AcIndex, wpname: RouteWaypoint) -> None:
    """DELWPT acid, wpname: delete a waypoint from the route (``*``: the whole route)."""
    if wpname == "*":
        delrte(sim, acid)
        return
    route = sim.edit_route(acid)
    index = route.find(wpname)
    if route.iactwp == index and index != len(route) - 1:
        sim.activate_waypoint(acid, index + 1)
    route.delete(index)
    route.plan()
    if not len(route):
        sim.set_navigation(acid, lnav=False, vnav=False, vnav_speed=False)


@command("DELRTE", aliases=("DELROUTE",), group="route")
def delrte(sim: CommandContext, acid: AcIndex) -> None:
    """DELRTE acid: delete the whole route; LNAV and VNAV off."""
    route = sim.edit_route(acid)
    route.waypoints.clear()
    route.iactwp = -1
    route.reset_modes()
    sim.set_navigation(acid, lnav=False, vnav=False, vnav_speed=False)


@command("DIRECT", aliases=("DIRECTTO", "DIRTO"), group="route")
def direct(sim: CommandContext, acid: AcIndex, wpname: RouteWaypoint) -> None:
    """DIRECT acid, wpname: fly straight to a waypoint of the route (LNAV on)."""
    route = sim.edit_route(acid)
    if wpname == "*":
        raise CommandError("DIRECT needs a waypoint name")
    sim.direct_to(acid, route.find(wpname))


@command("LNAV", group="route")
def lnav(sim: CommandContext, acid: AcIndex, on: OnOff | None = None) -> str | None:
    """LNAV acid, [ON/OFF]: lateral navigation along the route."""
    view = sim.view
    callsign = view.callsign(acid)
    if on is None:
        return f"{callsign}: LNAV is {'ON' if sim.view.lnav[acid] else 'OFF'}"
    if on:
        route = sim.edit_route(acid)
        if not len(route):
            raise CommandError(f"LNAV {callsign}: no waypoints or destination specified")
        if not sim.view.lnav[acid]:
            sim.resume_route(acid)
    else:
        sim.set_navigation(acid, lnav=False)
    return None


@command("VNAV", group="route")
def vnav(sim: CommandContext, acid: AcIndex, on: OnOff | None = None) -> str | None:
    """VNAV acid, [ON/OFF]: vertical navigation (route altitude and speed constraints); needs LNAV."""
    view = sim.view
    callsign = view.callsign(acid)
    if on is None:
        return f"{callsign}: VNAV is {'ON' if sim.view.vnav[acid] else 'OFF'}"
    if on:
        if not sim.view.lnav[acid]:
            raise CommandError(f"{callsign}: VNAV ON requires LNAV to be ON")
        route = sim.edit_route(acid)
        if not len(route):
            raise CommandError(f"VNAV {callsign}: no waypoints or destination specified")
        sim.engage_vnav(acid)
    else:
        sim.set_navigation(acid, vnav=False, vnav_speed=False)
    return None


@command("SWTOC", group="route")
def swtoc(sim: CommandContext, acid: AcIndex, on: OnOff | None = None) -> str | None:
    """SWTOC acid, [ON/OFF]: climb as early as possible (ON) or on a constant gradient (OFF)."""
    if on is None:
        return f"{sim.view.callsign(acid)}: SWTOC is {'ON' if sim.view.early_climb[acid] else 'OFF'}"
    sim.set_climb_profile(acid, early_climb=on)
    return None


@command("SWTOD", group="route")
def swtod(sim: CommandContext, acid: AcIndex, on: OnOff | None = None) -> str | None:
    """SWTOD acid, [ON/OFF]: descend as late as possible (ON) or on a constant gradient (OFF)."""
    if on is None:
        return f"{sim.view.callsign(acid)}: SWTOD is {'ON' if sim.view.late_descent[acid] else 'OFF'}"
    sim.set_climb_profile(acid, late_descent=on)
    return None


def at_do_command(text: str, acid: str, registry: Any, is_aircraft: Callable[[str], bool]) -> str:
    """The command line an ``AT acid wp DO text`` stores, by BlueSky's rule.

    A line that starts with a callsign is kept as it is. Otherwise, when the
    command takes a callsign first and its first argument is not one, the
    AT's aircraft is put in (``DO SPD 50`` -> ``SPD B001 50``); a line that
    names its aircraft (``DO SPD A001 50``) is kept. Both the live command and
    ``--strict`` use this function, so they agree.
    """
    name, args = next_arg(text)
    if not name or is_aircraft(name):
        return text
    spec = registry.get(name.upper())
    if spec is None:
        raise CommandError(f"DO: unknown command {name}")
    takes_acid = bool(spec.params and spec.params[0].argtype is ACID) or (spec.raw and spec.name == "ADDWPT")
    first_arg, _ = next_arg(args)
    if takes_acid and not (first_arg and is_aircraft(first_arg)):
        return f"{name} {acid} {args}".strip()
    return text


def check_at(argtext: str, ctx: Any) -> None:
    """Static check of AT arguments (``--strict``); a DO command is checked as a command."""
    _, rest = ACID.parse(argtext, ctx)
    _, rest = next_arg(rest)  # waypoint: routes exist only while simulating
    what, rest = next_arg(rest)
    what = what.upper()
    try:
        if not what:
            return
        if "/" in what and not rest.strip():
            alt_txt, spd_txt = what.split("/", 1)
            if alt_txt and alt_txt.count("-") <= 1:
                parse_altitude(alt_txt)
            if spd_txt and spd_txt.count("-") <= 1:
                parse_speed(spd_txt)
        elif what == "ALT" and rest.strip():
            parse_altitude(next_arg(rest)[0])
        elif what in ("SPD", "SPEED") and rest.strip():
            parse_speed(next_arg(rest)[0])
        elif what in ("DO", "STACK"):
            registry = getattr(ctx, "registry", None)
            if rest.strip() and hasattr(ctx, "check_nested") and registry is not None:
                acid = next_arg(argtext)[0].upper()
                known: set[str] = getattr(ctx, "callsigns", set())
                ctx.check_nested(at_do_command(rest.strip(), acid, registry, lambda n: n.upper() in known))
        elif what not in ("DEL", "DELETE", "CLR", "CLEAR", "ALT", "SPD", "SPEED"):
            raise CommandError(f"AT: unknown keyword {what}")
    except UnitParseError as exc:
        raise ArgumentError(str(exc)) from None


@command("AT", group="route")
@raw_arguments
@static_validator(check_at)
def at(sim: CommandContext, argtext: RestOfLine) -> str | None:
    """AT acid, wpname, [ALT alt | SPD spd | alt/spd | DO cmd | DEL ALT/SPD/BOTH/ALL]: waypoint constraints and commands.

    ``DO`` (or ``STACK``) stores a command run when the waypoint is passed;
    the callsign is added to it when the command expects one first.
    """
    ctx = LiveContext(sim)
    i, rest = ACID.parse(argtext, ctx)
    wpname, rest = WPINROUTE.parse(rest, ctx)
    view = sim.view
    route = sim.edit_route(i)
    acid = view.callsign(i)
    wp = route.waypoints[route.find(wpname)]
    what, rest = next_arg(rest)
    what = what.upper()
    if not what or what in ("ALT", "SPD", "SPEED", "DO", "STACK") and not rest.strip():
        alt_txt = "-----" if math.isnan(wp.alt) else f"{wp.alt / FT:.0f}"
        if math.isnan(wp.spd):
            spd_txt = "---"
        else:
            spd_txt = f"M{wp.spd:.3f}" if wp.spd_mach else f"{wp.spd / KTS:.0f}"
        lines = [f"{wp.name}: {alt_txt}/{spd_txt}"] + [f"DO {c}" for c in wp.stack]
        return "\n".join(lines)
    try:
        if "/" in what and not rest.strip():
            alt_txt, spd_txt = what.split("/", 1)
            wp.alt = math.nan if alt_txt.count("-") > 1 or not alt_txt else parse_altitude(alt_txt)
            if spd_txt.count("-") > 1 or not spd_txt:
                wp.spd, wp.spd_mach = math.nan, False
            else:
                speed = parse_speed(spd_txt)
                wp.spd, wp.spd_mach = speed.value, speed.is_mach
        elif what == "ALT":
            wp.alt = parse_altitude(next_arg(rest)[0])
        elif what in ("SPD", "SPEED"):
            speed = parse_speed(next_arg(rest)[0])
            wp.spd, wp.spd_mach = speed.value, speed.is_mach
        elif what in ("DO", "STACK"):
            wp.stack.append(at_do_command(rest.strip(), acid, sim.commands, lambda n: n.upper() in view))
            wp.stack_sources.append(sim.current_source)
        elif what in ("DEL", "DELETE", "CLR", "CLEAR"):
            which = next_arg(rest)[0].upper()
            if which in ("SPD", "SPEED", "BOTH", "ALL"):
                wp.spd, wp.spd_mach = math.nan, False
            if which in ("ALT", "BOTH", "ALL"):
                wp.alt = math.nan
            if which == "ALL":
                wp.stack.clear()
                wp.stack_sources.clear()
        else:
            raise CommandError(f"AT {acid} {wpname}: unknown keyword {what}")
    except UnitParseError as exc:
        raise ArgumentError(str(exc)) from None
    route.plan()
    if 0 <= route.iactwp < len(route):
        sim.activate_waypoint(i, route.iactwp)
    return None


@command("RTA", group="route")
def rta(sim: CommandContext, acid: AcIndex, wpname: RouteWaypoint, time_s: Seconds) -> None:
    """RTA acid, wpname, time: required time of arrival at a waypoint (book-keeping for delay metrics)."""
    route = sim.edit_route(acid)
    index = route.find(wpname)
    if index < 0:  # "*" or a name that left the route: -1 once set the last waypoint's RTA, or crashed
        raise CommandError(f"{sim.view.callsign(acid)} has no waypoint {wpname} in its route")
    route.waypoints[index].rta_s = time_s
    if index == len(route) - 1:
        sim.flight_record(acid).scheduled_arrival_s = time_s


@command("LISTRTE", group="route")
def listrte(sim: CommandContext, acid: AcIndex) -> str:
    """LISTRTE acid: show the route (name, position, constraints; * marks the active waypoint)."""
    route = sim.edit_route(acid)
    lines = [f"Route of {sim.view.callsign(acid)}:"]
    for k, wp in enumerate(route.waypoints):
        alt = "-----" if math.isnan(wp.alt) else f"{wp.alt / FT:.0f}"
        spd = "---" if math.isnan(wp.spd) else (f"M{wp.spd:.3f}" if wp.spd_mach else f"{wp.spd / KTS:.0f}")
        mark = "*" if k == route.iactwp else " "
        lines.append(f"{mark}{wp.name:<12} {wp.lat:10.5f} {wp.lon:11.5f} {alt:>6}/{spd}")
    return "\n".join(lines)


def _check_addwptmode(argtext: str, ctx: Any) -> None:
    _, rest = ACID.parse(argtext, ctx)
    if rest.strip() and waypoint_mode(rest) is None:
        raise ArgumentError(f'ADDWPTMODE: unknown mode "{next_arg(rest)[0]}"')
    mode_value = waypoint_mode(rest) if rest.strip() else None
    if mode_value is not None and mode_value[0] in _TURN_WORDS:
        parse_turn_value(*mode_value)


@command("ADDWPTMODE", group="route")
@raw_arguments
@static_validator(_check_addwptmode)
def addwptmode(sim: CommandContext, argtext: RestOfLine) -> str | None:
    """ADDWPTMODE acid, [FLYBY/FLYOVER/FLYTURN/TURNSPD/TURNRAD/TURNBANK/TURNHDG, value]: ADDWPT's mode words.

    Without a mode, tells the current one. Values have ADDWPT's units (kts,
    nm, deg, deg/s).
    """
    ctx = LiveContext(sim)
    i, rest = ACID.parse(argtext, ctx)
    route = sim.edit_route(i)
    if not rest.strip():
        return f"Current ADDWPT mode is {route.mode}."
    mode_value = waypoint_mode(rest)
    if mode_value is None:
        raise ArgumentError(f'ADDWPTMODE: unknown mode "{next_arg(rest)[0]}"')
    apply_waypoint_mode(route, *mode_value)
    return None


@command("CRUISESPD", group="route")
def cruisespd(sim: CommandContext, acid: AcIndex, spd: SpeedArg) -> None:
    """CRUISESPD acid, spd: the speed (kts CAS) selected when a fly-turn ends, if its new leg has no speed constraint."""
    if spd.is_mach:
        raise ArgumentError("CRUISESPD takes a CAS in knots")
    sim.set_cruise_speed(acid, spd.value)


COMMANDS = (addwpt, addwptmode, cruisespd, dest, orig, delwpt, delrte, direct, lnav, vnav, swtoc, swtod, at, rta,
            listrte)
