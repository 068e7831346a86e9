"""The separation standard: the loss-of-separation volumes that events, metrics and baselines count against.

A :class:`SeparationVolume` is one volume (a sphere on 3-D slant distance, or a cylinder); the
:class:`SeparationStandard` names the two every use case reads, the near mid-air collision (NMAC)
and loss of well clear (LoWC) volumes, in metres. The conflict service owns it (its volumes
``nmac`` and ``lowc``; ``SEPVOLUME`` changes them); the simulation exposes it as
``sim.separation_standard``. The default is the AAM-Gym paper's: spheres of 150 m and 450 m.

This module imports nothing of the simulation, so that anything may read the standard.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

NMAC = "nmac"  # the volume names the conflict service, the metrics and conflicts.csv use
LOWC = "lowc"


@dataclass(frozen=True)
class SeparationVolume:
    """A sphere (3-D slant distance < radius) or a cylinder (|dh| < radius and |dz| < half_height)."""

    name: str
    radius_m: float
    half_height_m: float | None = None

    @property
    def cylinder(self) -> bool:
        return self.half_height_m is not None

    @property
    def vertical_m(self) -> float:
        """The volume's vertical half-extent [m]: the half-height of a cylinder, the radius of a sphere."""
        return self.radius_m if self.half_height_m is None else self.half_height_m

    def describe(self) -> str:
        if self.cylinder:
            return f"{self.name}: cylinder r={self.radius_m:g} m, h=+-{self.half_height_m:g} m"
        return f"{self.name}: sphere r={self.radius_m:g} m (3-D slant)"


@dataclass(frozen=True)
class SeparationStandard:
    """The NMAC and LoWC volumes, SI units.

    A volume whose ``*_sphere`` flag is True is a sphere on 3-D slant distance of radius
    ``*_horizontal_m`` (its vertical extent, ``*_vertical_m``, is then the same number); otherwise a
    cylinder of that radius and half-height ``*_vertical_m``.
    """

    nmac_horizontal_m: float = 150.0  # m
    nmac_vertical_m: float = 150.0  # m
    lowc_horizontal_m: float = 450.0  # m
    lowc_vertical_m: float = 450.0  # m
    nmac_sphere: bool = True
    lowc_sphere: bool = True

    def __post_init__(self) -> None:
        for name in ("nmac_horizontal_m", "nmac_vertical_m", "lowc_horizontal_m", "lowc_vertical_m"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value <= 0:
                raise ValueError(f"SeparationStandard.{name} must be a distance above 0 m, not {value!r}")
        for volume in (NMAC, LOWC):
            if getattr(self, f"{volume}_sphere") and getattr(self, f"{volume}_vertical_m") != \
                    getattr(self, f"{volume}_horizontal_m"):
                raise ValueError(f"SeparationStandard: the {volume} sphere has one radius; {volume}_vertical_m "
                                 f"({getattr(self, f'{volume}_vertical_m')!r}) must equal {volume}_horizontal_m "
                                 f"({getattr(self, f'{volume}_horizontal_m')!r}), or set {volume}_sphere=False")

    @property
    def nmac(self) -> SeparationVolume:
        return SeparationVolume(NMAC, self.nmac_horizontal_m, None if self.nmac_sphere else self.nmac_vertical_m)

    @property
    def lowc(self) -> SeparationVolume:
        return SeparationVolume(LOWC, self.lowc_horizontal_m, None if self.lowc_sphere else self.lowc_vertical_m)

    def volumes(self) -> tuple[SeparationVolume, SeparationVolume]:
        """The NMAC and LoWC volumes, in that order."""
        return self.nmac, self.lowc

    @classmethod
    def from_volumes(cls, nmac: SeparationVolume, lowc: SeparationVolume) -> SeparationStandard:
        """The standard of two volumes (their names are not checked: the caller picked them)."""
        return cls(nmac.radius_m, nmac.vertical_m, lowc.radius_m, lowc.vertical_m,
                   nmac_sphere=not nmac.cylinder, lowc_sphere=not lowc.cylinder)


PAPER_STANDARD = SeparationStandard()  # the AAM-Gym paper's NMAC and LoWC spheres, 150 m and 450 m
