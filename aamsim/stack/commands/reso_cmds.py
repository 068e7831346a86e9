"""Conflict resolution: ``RESO`` and BlueSky's resolution settings (RMETHH, RMETHV, RFACH, RFACV, RSZONER,
RSZONEDH, PRIORULES, NORESO, RESOOFF), which the MVP service uses (:mod:`aamsim.resolution.mvp_service`)."""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from aamsim.errors import CommandError
from aamsim.stack.argtypes import Number, OnOff, RestOfLine, Text
from aamsim.stack.registry import command, raw_arguments
from aamsim.units import FT, NM

if TYPE_CHECKING:
    from aamsim.resolution.mvp_service import MVPService
    from aamsim.stack.context import CommandContext

RESO_METHODS = ("OFF", "MVP", "DAA")
# Methods of BlueSky's plugins (plugins/asas): BlueSky has them only with the plugin loaded.
BLUESKY_PLUGIN_METHODS = ("EBY", "SSD", "SWARM")


def _mvp(sim: CommandContext) -> MVPService:
    return sim.services.start().mvp


@command("RESO", group="conflicts")
def reso(sim: CommandContext, method: Text = "") -> str | None:
    """RESO [OFF/MVP/DAA]: conflict resolution method: MVP (BlueSky's Modified Voltage Potential) or DAA
    (the detect-and-avoid service's speed advisories).

    MVP's settings: RMETHH, RMETHV, RFACH, RFACV, RSZONER, RSZONEDH,
    PRIORULES, NORESO, RESOOFF; DAA's thresholds: the DAA command
    (DO-365/DAIDALUS). OFF: none (conflicts are only detected).
    """
    if not method:
        return f"conflict resolution: {sim.settings.reso}; available: {', '.join(RESO_METHODS)}"
    if method not in RESO_METHODS:
        if method in BLUESKY_PLUGIN_METHODS:
            raise CommandError(f"RESO {method} is a method of a BlueSky plugin (plugins/asas), not built into "
                               f"aamsim; available: {', '.join(RESO_METHODS)}")
        raise CommandError(f"RESO {method}: no such resolution method; available: {', '.join(RESO_METHODS)}")
    sim.settings.reso = method
    if method != "OFF":
        sim.services.start()  # the service acts from its next cycle on
    return None


def _setting(sim: CommandContext, change) -> None:  # type: ignore[no-untyped-def]
    try:
        change(_mvp(sim).settings)
    except ValueError as exc:
        raise CommandError(str(exc)) from None


@command("RMETHH", group="conflicts")
def rmethh(sim: CommandContext, value: Text = "") -> str | None:
    """RMETHH [ON/BOTH/SPD/HDG/OFF/NONE]: horizontal resolutions only, by heading and speed, speed or heading;
    OFF/NONE lifts the horizontal restriction."""
    if not value:
        return _mvp(sim).settings.describe()
    _setting(sim, lambda s: s.set_horizontal(value))
    return None


@command("RMETHV", group="conflicts")
def rmethv(sim: CommandContext, value: Text = "") -> str | None:
    """RMETHV [ON/V/S/OFF/NONE]: vertical resolutions only (ON, V/S), or lift that restriction (OFF, NONE)."""
    if not value:
        return _mvp(sim).settings.describe()
    _setting(sim, lambda s: s.set_vertical(value))
    return None


def _factor(value: float, what: str) -> float:
    if not 0.0 < value <= 100.0:
        raise CommandError(f"{what} must be above 0 and at most 100, not {value:g}")
    return value


@command("RFACH", aliases=("RESOFACH", "HRFAC", "HRESOFAC"), group="conflicts")
def rfach(sim: CommandContext, factor: Number | None = None) -> str | None:
    """RFACH [factor]: horizontal resolution zone = protected zone x factor (default 1.05)."""
    settings = _mvp(sim).settings
    if factor is None:
        return f"horizontal resolution factor {settings.factor_h:g}"
    settings.factor_h = _factor(factor, "RFACH")
    settings.zone_r_relative = True
    return None


@command("RFACV", aliases=("RESOFACV",), group="conflicts")
def rfacv(sim: CommandContext, factor: Number | None = None) -> str | None:
    """RFACV [factor]: vertical resolution zone = protected zone x factor (default 1.05)."""
    settings = _mvp(sim).settings
    if factor is None:
        return f"vertical resolution factor {settings.factor_v:g}"
    settings.factor_v = _factor(factor, "RFACV")
    settings.zone_dh_relative = True
    return None


@command("RSZONER", aliases=("RESOZONER",), group="conflicts")
def rszoner(sim: CommandContext, radius_nm: Number | None = None) -> str | None:
    """RSZONER [radius]: horizontal resolution zone radius [NM] (sets RFACH = radius / ZONER; kept when ZONER
    changes)."""
    settings = _mvp(sim).settings
    zoner_m = sim.settings.zoner_m
    if radius_nm is None:
        return f"resolution zone radius {settings.factor_h * zoner_m / NM:g} NM (RFACH {settings.factor_h:g})"
    settings.factor_h = _factor(radius_nm * NM / zoner_m, "RSZONER / ZONER")
    settings.zone_r_relative = False
    return None


@command("RSZONEDH", aliases=("RESOZONEDH",), group="conflicts")
def rszonedh(sim: CommandContext, height_ft: Number | None = None) -> str | None:
    """RSZONEDH [height]: vertical resolution zone [ft] (sets RFACV = height / ZONEDH; kept when ZONEDH changes)."""
    settings = _mvp(sim).settings
    zonedh_m = sim.settings.zonedh_m
    if height_ft is None:
        return f"resolution zone height {settings.factor_v * zonedh_m / FT:g} ft (RFACV {settings.factor_v:g})"
    settings.factor_v = _factor(height_ft * FT / zonedh_m, "RSZONEDH / ZONEDH")
    settings.zone_dh_relative = False
    return None


@command("PRIORULES", group="conflicts")
def priorules(sim: CommandContext, flag: OnOff | None = None, code: Text = "") -> str | None:
    """PRIORULES [ON/OFF] [FF1/FF2/FF3/LAY1/LAY2]: right-of-way rules of MVP.

    FF1: no priority; FF2: cruising aircraft have priority; FF3: climbing and
    descending aircraft have priority; LAY1, LAY2: as FF2, FF3 with horizontal
    resolutions only. As BlueSky, a code is needed with OFF too.
    """
    settings = _mvp(sim).settings
    if flag is None:
        return settings.describe()
    _setting(sim, lambda s: s.set_priority(flag, code))
    return None


_SEPARATORS = re.compile(r"[\s,]+")


def _callsigns(sim: CommandContext, argtext: str, name: str) -> list[str]:
    names = [a.upper() for a in _SEPARATORS.split(argtext.strip()) if a]
    unknown = [a for a in names if a not in sim.view]
    if unknown:
        raise CommandError(f"{name}: no aircraft {', '.join(unknown)}")
    return names


@command("NORESO", group="conflicts")
@raw_arguments
def noreso(sim: CommandContext, argtext: RestOfLine = "") -> str | None:
    """NORESO [acid, ...]: aircraft that nobody avoids (each listed one is added, or removed if it was in)."""
    service = _mvp(sim)
    if not argtext.strip():
        return "aircraft nobody avoids: " + (", ".join(sorted(service.no_reso)) or "none")
    service.toggle(service.no_reso, _callsigns(sim, argtext, "NORESO"))
    return None


@command("RESOOFF", group="conflicts")
@raw_arguments
def resooff(sim: CommandContext, argtext: RestOfLine = "") -> str | None:
    """RESOOFF [acid, ...]: aircraft that avoid nobody (each listed one is added, or removed if it was in)."""
    service = _mvp(sim)
    if not argtext.strip():
        return "aircraft that avoid nobody: " + (", ".join(sorted(service.reso_off)) or "none")
    service.toggle(service.reso_off, _callsigns(sim, argtext, "RESOOFF"))
    return None


COMMANDS = (reso, rmethh, rmethv, rfach, rfacv, rszoner, rszonedh, priorules, noreso, resooff)
