"""Conflict-detection settings, as BlueSky's ASAS commands (used by aamsim.conflicts)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from aamsim.errors import CommandError
from aamsim.stack.argtypes import Number, RestOfLine, Seconds, Text
from aamsim.stack.registry import command, raw_arguments
from aamsim.units import FT, NM

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

CD_METHODS = {"ON": "STATEBASED", "OFF": "OFF", "STATEBASED": "STATEBASED", "CSTATEBASED": "STATEBASED"}


@command("ASAS", aliases=("CDMETHOD",), group="conflicts")
def asas(sim: CommandContext, method: Text = "") -> str | None:
    """ASAS [ON/OFF/STATEBASED]: switch state-based conflict detection (CDMETHOD is the same command)."""
    if not method:
        return f"conflict detection: {sim.settings.cd_method}"
    if method not in CD_METHODS:
        raise CommandError(f"unknown conflict detection method {method} (ON, OFF, STATEBASED)")
    sim.settings.cd_method = CD_METHODS[method]
    return None


# Largest separation distances and look-ahead accepted: beyond them the conflict search's grid
# overflows (SEPVOLUME LOWC 1e308 crashed the pair search, found by tests/fuzz).
MAX_SEPARATION_M = 1_000_000.0  # 1,000 km
MAX_LOOKAHEAD_S = 86_400.0  # a day


def _positive_up_to(value: float, limit: float, what: str, unit: str) -> float:
    if not 0.0 < value <= limit:
        raise CommandError(f"{what} must be positive and at most {limit:g} {unit}, not {value:g}")
    return value


@command("ZONER", aliases=("PZR", "RPZ", "PZRADIUS"), group="conflicts")
def zoner(sim: CommandContext, radius_nm: Number | None = None) -> str | None:
    """ZONER [radius]: horizontal protected-zone radius [NM] (default 5; 450 m is 0.243)."""
    if radius_nm is None:
        return f"PZ radius {sim.settings.zoner_m / NM:g} NM ({sim.settings.zoner_m:.1f} m)"
    old = sim.settings.zoner_m
    sim.settings.zoner_m = _positive_up_to(radius_nm * NM, MAX_SEPARATION_M, "the protected-zone radius", "m")
    mvp = sim.services.mvp.settings if sim.services.started else None
    if mvp is not None and not mvp.zone_r_relative:
        mvp.factor_h *= old / sim.settings.zoner_m  # RSZONER gave a radius: it stays (as BlueSky)
    return None


@command("ZONEDH", aliases=("PZDH", "DHPZ", "PZHEIGHT"), group="conflicts")
def zonedh(sim: CommandContext, height_ft: Number | None = None) -> str | None:
    """ZONEDH [height]: vertical protected-zone half-height [ft] (default 1000)."""
    if height_ft is None:
        return f"PZ half-height {sim.settings.zonedh_m / FT:g} ft"
    old = sim.settings.zonedh_m
    sim.settings.zonedh_m = _positive_up_to(height_ft * FT, MAX_SEPARATION_M, "the protected-zone height", "m")
    mvp = sim.services.mvp.settings if sim.services.started else None
    if mvp is not None and not mvp.zone_dh_relative:
        mvp.factor_v *= old / sim.settings.zonedh_m  # RSZONEDH gave a height: it stays (as BlueSky)
    return None


@command("DTLOOK", group="conflicts")
def dtlook(sim: CommandContext, time_s: Seconds | None = None) -> str | None:
    """DTLOOK [time]: conflict-detection look-ahead time [s] (default 300)."""
    if time_s is None:
        return f"look-ahead {sim.settings.dtlook_s:g} s"
    sim.settings.dtlook_s = _positive_up_to(time_s, MAX_LOOKAHEAD_S, "the look-ahead time", "s")
    return None


@command("SEPVOLUME", aliases=("LOSVOLUME",), group="conflicts")
def sepvolume(sim: CommandContext, name: Text = "", radius_m: Number | None = None,
              half_height_m: Number | None = None) -> str | None:
    """SEPVOLUME [NMAC/LOWC/name, radius, [half_height]]: a loss-of-separation volume [m].

    Radius alone: a sphere on 3-D slant distance (the paper's NMAC 150 m and
    LoWC 450 m); with a half-height: a cylinder, as detect-and-avoid standards
    define them. Without arguments, list the volumes.
    """
    from aamsim.conflicts.service import SeparationVolume

    if not name:  # a listing does not start conflict detection
        return "\n".join(v.describe() for v in sim.services.conflicts.volumes)
    service = sim.services.start().conflicts
    if radius_m is None or not 0 < radius_m <= MAX_SEPARATION_M or (
            half_height_m is not None and not 0 < half_height_m <= MAX_SEPARATION_M):
        raise CommandError(f"SEPVOLUME needs a radius [m] (and, for a cylinder, a half-height [m]) above 0 and at "
                           f"most {MAX_SEPARATION_M:g} m")
    service.set_volume(SeparationVolume(name.lower(), radius_m, half_height_m))
    return None


def _accepted_setting(name: str):
    @command(name, group="conflicts")
    @raw_arguments
    def handler(sim: CommandContext, argtext: RestOfLine) -> None:
        sim.note_once(name, f"{name} is accepted and ignored by aamsim's conflict detection", sim.current_source)

    handler.__doc__ = f"{name} ...: BlueSky conflict-detection setting, accepted and ignored."
    return handler


COMMANDS = (asas, zoner, zonedh, dtlook, sepvolume) + tuple(
    _accepted_setting(n) for n in ("DTNOLOOK", "CDSPEEDCHANGE")
)
