"""A use case's NMAC and LoWC distances: the simulation's separation standard unless the use case sets its own.

One standard counts every NMAC and LoWC: the conflict service's
(:attr:`aamsim.SimulationAPI.separation_standard`; ``SEPVOLUME`` in a scenario changes it). A
use case's ``nmac_m`` / ``lowc_m`` parameters default to None, which keeps that standard (the
AAM-Gym paper's 150 m and 450 m spheres unless the scenario or the simulation says otherwise); a
number replaces the volume by a sphere of that radius when the use case attaches. Rewards and
observations then read the distances back from the simulation (:func:`nmac_distance`,
:func:`lowc_distance`), so the events counted and the rewards given use the same numbers.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any


def check_distances(params: Any, *names: str) -> None:
    """Raise ValueError naming the first of ``names`` that is set and not above 0 m (None: the standard's)."""
    for name in names:
        value = getattr(params, name)
        if value is not None and not value > 0:
            raise ValueError(f"{name} must be positive (or None: the simulation's separation standard), "
                             f"not {value!r}")


def apply_separation(sim: Any, nmac_m: float | None, lowc_m: float | None) -> None:
    """Make the simulation's NMAC / LoWC volumes spheres of ``nmac_m`` / ``lowc_m`` [m]; None keeps that volume."""
    if nmac_m is None and lowc_m is None:
        return
    std = sim.separation_standard
    if nmac_m is not None:
        std = replace(std, nmac_horizontal_m=float(nmac_m), nmac_vertical_m=float(nmac_m), nmac_sphere=True)
    if lowc_m is not None:
        std = replace(std, lowc_horizontal_m=float(lowc_m), lowc_vertical_m=float(lowc_m), lowc_sphere=True)
    sim.set_separation_standard(std)


def nmac_distance(sim: Any) -> float:
    """The simulation's NMAC distance now (the radius of its NMAC volume) [m]."""
    return float(sim.separation_standard.nmac_horizontal_m)


def lowc_distance(sim: Any) -> float:
    """The simulation's LoWC distance now (the radius of its LoWC volume) [m]."""
    return float(sim.separation_standard.lowc_horizontal_m)
