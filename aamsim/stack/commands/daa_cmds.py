"""Detect and avoid: the ``DAA`` settings command (``RESO DAA`` switches the service on, see asas_cmds)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from aamsim.errors import CommandError
from aamsim.stack.argtypes import RestOfLine, Text
from aamsim.stack.registry import command
from aamsim.units import FPM, FT

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

# Stack name -> (DAAParams field, unit in the stack, factor to SI).
DAA_SETTINGS: dict[str, tuple[str, str, float]] = {
    "DMOD": ("dmod_m", "m", 1.0),
    "HMD": ("hmd_m", "m", 1.0),
    "TAUMOD": ("taumod_s", "s", 1.0),
    "ZTHR": ("zthr_m", "m", 1.0),
    "TCOA": ("tcoa_s", "s", 1.0),
    "ZTHRPREV": ("preventive_zthr_m", "m", 1.0),
    "TPREV": ("preventive_s", "s", 1.0),
    "TCORR": ("corrective_s", "s", 1.0),
    "TWARN": ("warning_s", "s", 1.0),
    "LOOKAHEAD": ("lookahead_s", "s", 1.0),
    "RECOVERY": ("recovery_m", "m", 1.0),
    "RECOVERYZ": ("recovery_zthr_m", "m", 1.0),
    "RECOVERYT": ("recovery_lookahead_s", "s", 1.0),
    "SPDMIN": ("speed_min_kts", "kt", 1.0),
    "SPDMAX": ("speed_max_kts", "kt", 1.0),
    "MARGIN": ("margin_mps", "m/s", 1.0),
    "LEVEL": ("resolve_level", "", 1.0),
    "INTERVAL": ("interval_s", "s", 1.0),
    "HYSTERESIS": ("hysteresis_s", "s", 1.0),
    "HDGSTEP": ("hdg_step_deg", "deg", 1.0),
    "HDGMARGIN": ("hdg_margin_deg", "deg", 1.0),
    "MAXTURN": ("max_turn_deg", "deg", 1.0),
    "VSMAX": ("vs_max_mps", "fpm", FPM),
    "VSMARGIN": ("vs_margin_mps", "fpm", FPM),
    "ALTMIN": ("alt_min_m", "ft", FT),
    "ALTMAX": ("alt_max_m", "ft", FT),
}
AXES_SETTING = "RESOAXES"  # the resolution axes, in order of preference: HDG, VS, GS


def _show(params: object, name: str) -> str:
    if name == AXES_SETTING:
        return f"{name} {' '.join(a.upper() for a in params.resolution_axes)}"  # type: ignore[attr-defined]
    fld, unit, factor = DAA_SETTINGS[name]
    return f"{name} {getattr(params, fld) / factor:g} {unit}".rstrip()


def describe(sim: CommandContext) -> str:
    params = sim.services.start().daa.daa.params
    return "\n".join(_show(params, name) for name in (*DAA_SETTINGS, AXES_SETTING))


@command("DAA", group="conflicts")
def daa(sim: CommandContext, name: Text = "", value: RestOfLine = "") -> str | None:
    """DAA [setting value]: a detect-and-avoid threshold (RESO DAA switches the service on).

    Settings (SI units): DMOD, HMD [m], TAUMOD [s], ZTHR [m], TCOA [s] of the
    well-clear volume; ZTHRPREV [m], the preventive volume's ZTHR; TPREV, TCORR,
    TWARN [s], the alerting times of the preventive, corrective and warning
    levels; LOOKAHEAD [s] of the bands; RECOVERY, RECOVERYZ [m], the recovery
    volume used when every speed loses well clear, and RECOVERYT [s], how long
    a recovery speed must stay clear of it; SPDMIN, SPDMAX [kt CAS], the
    resolution speeds; MARGIN [m/s] inside a band; LEVEL (1-3), the alert level
    that gets a resolution; INTERVAL [s], the cycle; HYSTERESIS [s], how long
    an aircraft stays clear of conflict before its advisory is released. RESOAXES: the axes resolved
    on, in order of preference (HDG, VS, GS; default all three); HDGSTEP,
    HDGMARGIN, MAXTURN [deg] of heading resolutions; VSMAX, VSMARGIN [fpm] of
    vertical-speed resolutions, which stay between ALTMIN and ALTMAX [ft].
    Without arguments, list them.
    """
    if not name:
        return describe(sim)
    if name != AXES_SETTING and name not in DAA_SETTINGS:
        raise CommandError(f"unknown DAA setting {name}; known: {', '.join((*DAA_SETTINGS, AXES_SETTING))}")
    service = sim.services.start().daa
    words = value.replace(",", " ").split()
    if not words:
        return _show(service.daa.params, name)
    try:
        if name == AXES_SETTING:
            service.daa.set(resolution_axes=tuple(words))
            return None
        fld, _unit, factor = DAA_SETTINGS[name]
        if len(words) != 1:
            raise ValueError(f"{name} takes one number, not {value.strip()!r}")
        try:
            number = float(words[0])
        except ValueError:
            raise ValueError(f"{name}: {words[0]!r} is not a number") from None
        service.daa.set(**{fld: int(number) if fld == "resolve_level" else number * factor})
    except ValueError as exc:
        raise CommandError(str(exc)) from exc
    return None


COMMANDS = (daa,)
