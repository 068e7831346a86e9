"""Schedule -> BlueSky scenario text.

Each flight becomes a block of commands at its departure time that both
BlueSky 1.1.1 and aamsim run the same way::

    CRE <callsign> <type> <origin lat> <origin lon> <hdg to 1st waypoint> <lane ft + noise> 0
    ORIG / DEST <vertiport>        route = [origin, nodes..., destination]
    ADDWPT <node> ...              inserted before DEST; the first one is active
    VNAV OFF                       DEST switched VNAV on; the lane altitude is kept
    SPD <cruise kts>               spawned at 0 kt, it accelerates
    RTA <dest> <scheduled arrival> book-keeping for delay metrics
    <callsign> ATDIST <dest lat> <dest lon> 0.05 DEL <callsign>   removed on arrival

Named points are defined once at the top with ``DEFWPT``; their scenario
names (``NYV01``, ``NYN001``...) are built from the network's
``scenario_prefix`` and the file order, so that they never clash with
BlueSky's navigation database.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import IO

import numpy as np

from aamsim.geo import qdrdist
from aamsim.units import format_time
from uamtoolkit_import.fields import aircraft_type_problem, comment_text
from uamtoolkit_import.network import Network
from uamtoolkit_import.schedule import Schedule, ScheduledFlight
from uamtoolkit_import.times import format_clock

ARRIVAL_RADIUS_NM = 0.05


@dataclass(frozen=True)
class ConvertOptions:
    """How a schedule becomes a scenario.

    Attributes:
        start_s, end_s: keep flights departing in ``[start_s, end_s)`` [s since
            midnight]; times are rebased so that ``start_s`` is 00:00:00.
            ``end_s`` None: no upper bound.
        alt_noise_ft: half-width of the uniform altitude noise [ft].
        aircraft_type: BlueSky type for every flight; ``"SCHEDULE"`` uses the
            schedule's own type column.
        seed: seeds the altitude noise (same seed, same file).
        header: extra comment lines for the top of the file.
    """

    start_s: float = 0.0
    end_s: float | None = None
    alt_noise_ft: float = 100.0
    aircraft_type: str = "EC35"
    seed: int = 0
    header: tuple[str, ...] = ()


@dataclass
class Conversion:
    """The scenario text and what went into it."""

    text: str  # empty when :func:`write_scenario` wrote it to a stream
    written: list[ScheduledFlight]
    outside_window: int
    names: dict[str, str] = field(default_factory=dict)


def scenario_names(network: Network) -> dict[str, str]:
    """Network point id -> scenario waypoint name (``<prefix>V01``, ``<prefix>N001``)."""
    prefix = network.scenario_prefix
    vwidth = max(2, len(str(len(network.vertiports))))
    nwidth = max(3, len(str(len(network.nodes))))
    names = {vid: f"{prefix}V{k:0{vwidth}d}" for k, vid in enumerate(network.vertiports, start=1)}
    names.update({nid: f"{prefix}N{k:0{nwidth}d}" for k, nid in enumerate(network.nodes, start=1)})
    return names


def _noise_draws(schedule: Schedule, options: ConvertOptions) -> np.ndarray:
    """One uniform draw per line number up to the last valid row [ft] (index = row)."""
    if not schedule.flights:
        return np.zeros(0)
    last_row = max(f.row for f in schedule.flights)
    rng = np.random.default_rng(options.seed)
    return rng.uniform(-options.alt_noise_ft, options.alt_noise_ft, size=last_row + 1)


def altitude_noise_ft(schedule: Schedule, options: ConvertOptions) -> dict[int, float]:
    """Uniform noise in [-alt_noise_ft, +alt_noise_ft] per schedule row [ft].

    The draw depends only on the seed and the row number, so a flight keeps
    its altitude whatever time window is converted.
    """
    draws = _noise_draws(schedule, options)
    return {f.row: float(draws[f.row]) for f in schedule.flights}


def in_window(departure_s: float, options: ConvertOptions) -> bool:
    return departure_s >= options.start_s and (options.end_s is None or departure_s < options.end_s)


def _fmt(x: float, decimals: int) -> str:
    """A number with at most ``decimals`` decimals and no trailing zeros."""
    text = f"{x:.{decimals}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def flight_block(
    flight: ScheduledFlight,
    network: Network,
    names: dict[str, str],
    t0_s: float,
    alt_noise_ft: float,
    aircraft_type: str,
) -> list[str]:
    """The commands of one flight, each prefixed by its (rebased) time."""
    cs = flight.callsign
    stamp = format_time(flight.departure_s - t0_s) + ">"
    olat, olon = network.position(flight.origin)
    dlat, dlon = network.position(flight.destination)
    first = flight.route[0] if flight.route else flight.destination
    flat, flon = network.position(first)
    hdg = qdrdist(olat, olon, flat, flon)[0] % 360.0
    alt_ft = flight.cruise_alt_ft + alt_noise_ft
    lines = [
        f"CRE {cs} {aircraft_type} {olat:.6f} {olon:.6f} {_fmt(hdg, 1)} {_fmt(alt_ft, 1)} 0",
        f"ORIG {cs} {names[flight.origin]}",
        f"DEST {cs} {names[flight.destination]}",
        *(f"ADDWPT {cs} {names[node]}" for node in flight.route),
        f"VNAV {cs} OFF",
        f"SPD {cs} {_fmt(flight.cruise_speed_kts, 1)}",
    ]
    if math.isfinite(flight.arrival_s):
        lines.append(f"RTA {cs} {names[flight.destination]} {format_time(flight.arrival_s - t0_s)}")
    lines.append(f"{cs} ATDIST {dlat:.6f} {dlon:.6f} {ARRIVAL_RADIUS_NM} DEL {cs}")
    return [stamp + line for line in lines]


def convert(schedule: Schedule, network: Network, options: ConvertOptions | None = None) -> Conversion:
    """Turn a validated schedule into scenario text (flights outside the window are left out)."""
    buf = io.StringIO()
    result = write_scenario(schedule, network, buf, options)
    result.text = buf.getvalue()
    return result


def write_scenario(
    schedule: Schedule, network: Network, out: IO[str], options: ConvertOptions | None = None
) -> Conversion:
    """Write the scenario to ``out`` flight by flight (a million flights never make one string).

    The flights in the window are ordered by (departure, row) with an index sort over two
    arrays, not by sorting objects.
    """
    options = options or ConvertOptions()
    if options.aircraft_type.upper() != "SCHEDULE" and (problem := aircraft_type_problem(options.aircraft_type)):
        raise ValueError(f"aircraft type: {problem}")
    names = scenario_names(network)
    draws = _noise_draws(schedule, options)
    window = [f for f in schedule.flights if in_window(f.departure_s, options)]
    order = np.lexsort((np.fromiter((f.row for f in window), np.int64, len(window)),
                        np.fromiter((f.departure_s for f in window), np.float64, len(window))))
    kept = [window[i] for i in order]
    del window
    used: set[str] = set()
    for f in kept:
        used.update((f.origin, f.destination, *f.route))
    out.write("\n".join(_header(schedule, network, options, kept, names, used)) + "\n")
    for pid in network.point_ids:
        if pid in used:
            lat, lon = network.position(pid)
            out.write(f"00:00:00.00>DEFWPT {names[pid]} {lat:.6f} {lon:.6f}\n")
    by_type = options.aircraft_type.upper() == "SCHEDULE"
    for f in kept:
        actype = (f.aircraft_type or "EC35") if by_type else options.aircraft_type
        out.write("\n".join(flight_block(f, network, names, options.start_s, float(draws[f.row]), actype.upper())))
        out.write("\n")
    return Conversion("", kept, len(schedule.flights) - len(kept), names)


def _header(
    schedule: Schedule,
    network: Network,
    options: ConvertOptions,
    kept: Sequence[ScheduledFlight],
    names: dict[str, str],
    used: set[str],
) -> list[str]:
    window = f"{format_clock(options.start_s)} to {'end' if options.end_s is None else format_clock(options.end_s)}"
    # Comment text is escaped as well as checked where it is read: a line break in it would start a command.
    lines = [f"# {comment_text(line)}" for line in options.header]
    lines += [
        f"# Converted by uam2scn from {comment_text(schedule.path)}",
        f"# with network '{comment_text(network.name)}'.",
        f"# {len(kept)} flights departing {window} (times rebased: {format_clock(options.start_s)} -> 00:00:00);",
        f"# altitude noise uniform +-{_fmt(options.alt_noise_ft, 1)} ft (seed {options.seed});",
        f"# aircraft removed within {ARRIVAL_RADIUS_NM} NM of their destination.",
        "# Waypoints:",
    ]
    for pid in network.point_ids:
        if pid in used:
            label = network.vertiports[pid].name if pid in network.vertiports else network.nodes[pid].corridor
            lines.append(f"#   {names[pid]} = {comment_text(pid)} ({comment_text(label)})")
    return lines
