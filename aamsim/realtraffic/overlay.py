"""Overlays: a recording file or live OpenSky traffic replayed into a simulation, by one call.

``REPLAY``, ``aamsim run --overlay`` and the use cases' ``overlay`` parameter all come here. It
imports both the recording replay and the live feed, which keeps those two modules free of
each other (the live feed is a source of the replay; the replay knows nothing of it).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from aamsim.errors import CommandError
from aamsim.realtraffic.live import start_live
from aamsim.realtraffic.replay import BBox, Replay, parse_area, start_recording

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext


def start_overlay(sim: CommandContext, spec: str, offset: str = "", area: BBox | None = None,
                  name: str | None = None) -> Replay:
    """Overlay real traffic: ``spec`` a recording file (a path here, or one the scenario's search path
    finds) or ``opensky:LAT0,LON0,LAT1,LON1`` (live OpenSky state vectors, paced to real time)."""
    if spec.lower().startswith("opensky:"):
        if not sim.limits.live_data:  # a server's client: no network polls unless the server allows them
            raise CommandError(sim.limits.refusal("live OpenSky overlays are not allowed in this simulation"))
        try:
            box = parse_area([float(x) for x in spec.split(":", 1)[1].split(",") if x.strip()])
        except ValueError:
            box = None
        if box is None:
            raise CommandError(f'"{spec}": live OpenSky needs an area, opensky:LAT0,LON0,LAT1,LON1 in degrees')
        return start_live(sim, box)
    path = Path(spec)
    return start_recording(sim, str(path.resolve()) if path.is_file() else spec, offset, area, name=name or spec)
