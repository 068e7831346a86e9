"""Run-wide settings of a simulation, most of them set by stack commands.

The time step is not here: the clock owns it (:class:`aamsim.clock.Clock`).
"""

from __future__ import annotations

from dataclasses import dataclass

from aamsim.units import FT, KTS, NM


@dataclass
class SimSettings:
    """Run-wide settings (stack commands change most of them)."""

    perf_interval_s: float = 1.0
    delete_on_arrival: bool = False
    arrival_radius_m: float = 0.1 * NM
    hold_speed_mps: float = 5.0 * KTS
    airborne_alt_m: float = 10.0 * FT
    mcre_area: tuple[float, float, float, float] = (-1.0, -1.0, 1.0, 1.0)  # lat0, lon0, lat1, lon1
    # Conflict detection, as BlueSky's ASAS settings (used by aamsim.conflicts).
    cd_method: str = "OFF"
    zoner_m: float = 5.0 * NM
    zonedh_m: float = 1000.0 * FT
    dtlook_s: float = 300.0
    cd_interval_s: float = 1.0
    reso: str = "OFF"
