"""Real air traffic overlaid on the scenario: ``REPLAY`` (docs/real-traffic.md)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from aamsim.errors import CommandError
from aamsim.stack.argtypes import Number, Word
from aamsim.stack.registry import command

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext


@command("REPLAY", group="traffic")
def replay(sim: CommandContext, source: Word = "", offset: Word = "", *area: Number) -> str | None:
    """REPLAY file, [offset], [lat0, lon0, lat1, lon1]: overlay recorded real traffic (OpenSky, traffic library) as non-cooperative intruders.

    Each recorded aircraft flies its interpolated track (on-ground reports left out, gaps over
    60 s split it), named RT<icao24>; conflict detection and the NMAC/LoWC events see it, use
    cases observe it as an intruder, and it refuses every intent. ``offset``: the scenario time
    of the recording's first report (default 0; [-][[HH:]MM:]SS), or ``@UTC-TIME`` (ISO 8601 or
    s since 1970) for the recording's moment played at time 0. ``area``: keep only reports in
    that box [deg]. ``source`` may be ``OPENSKY`` (live, needs the area). Without arguments: the
    replays running.
    """
    from aamsim.realtraffic.overlay import start_overlay
    from aamsim.realtraffic.replay import parse_area, replays_of

    if not source:
        replays = replays_of(sim)
        if not replays:
            return "no replay running"
        return "\n".join(r.describe() for r in replays)
    box = parse_area(list(area))
    if source.upper() == "OPENSKY":
        if box is None:
            raise CommandError("REPLAY OPENSKY needs an area: REPLAY OPENSKY,,LAT0,LON0,LAT1,LON1")
        source = "opensky:" + ",".join(f"{v:g}" for v in box)
    start_overlay(sim, source, offset, box)
    return None


COMMANDS = (replay,)
