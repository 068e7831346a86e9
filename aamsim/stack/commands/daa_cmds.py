"""Detect and avoid: the ``DAA`` settings command (``RESO DAA`` switches the service on, see asas_cmds)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from aamsim.errors import CommandError
from aamsim.stack.argtypes import Number, Text
from aamsim.stack.registry import command

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
}


def describe(sim: CommandContext) -> str:
    params = sim.require_services().daa.daa.params
    return "\n".join(f"{name} {getattr(params, fld):g} {unit}".rstrip() for name, (fld, unit, _) in
                     DAA_SETTINGS.items())


@command("DAA", group="conflicts")
def daa(sim: CommandContext, name: Text = "", value: Number | None = None) -> str | None:
    """DAA [setting value]: a detect-and-avoid threshold (RESO DAA switches the service on).

    Settings (SI units): DMOD, HMD [m], TAUMOD [s], ZTHR [m], TCOA [s] of the
    well-clear volume; ZTHRPREV [m], the preventive volume's ZTHR; TPREV, TCORR,
    TWARN [s], the alerting times of the preventive, corrective and warning
    levels; LOOKAHEAD [s] of the bands; RECOVERY, RECOVERYZ [m], the recovery
    volume used when every speed loses well clear, and RECOVERYT [s], how long
    a recovery speed must stay clear of it; SPDMIN, SPDMAX [kt CAS], the
    resolution speeds; MARGIN [m/s] inside a band; LEVEL (1-3), the alert level
    that gets a resolution; INTERVAL [s], the cycle. Without arguments, list them.
    """
    if not name:
        return describe(sim)
    if name not in DAA_SETTINGS:
        raise CommandError(f"unknown DAA setting {name}; known: {', '.join(DAA_SETTINGS)}")
    fld, unit, factor = DAA_SETTINGS[name]
    service = sim.require_services().daa
    if value is None:
        return f"{name} {getattr(service.daa.params, fld):g} {unit}".rstrip()
    try:
        service.daa.set(**{fld: int(value) if fld == "resolve_level" else value * factor})
    except ValueError as exc:
        raise CommandError(str(exc)) from exc
    return None


COMMANDS = (daa,)
