"""Named positions: scenario-defined waypoints (DEFWPT) and, when the BlueSky
navigation data is installed (``pip install bluesky-simulator``), its airports,
navaids and fixes.

A name can denote several places (fixes are not unique worldwide); a lookup
returns the one nearest the reference position, as BlueSky does.
"""

from __future__ import annotations

import functools
import importlib.util
import math
from dataclasses import dataclass, field
from pathlib import Path

NamedPlaces = dict[str, list[tuple[float, float]]]


@dataclass
class NavDatabase:
    """Per-simulation named positions; the BlueSky data is shared read-only."""

    use_bluesky_data: bool = True
    user: NamedPlaces = field(default_factory=dict)

    def define(self, name: str, lat: float, lon: float) -> None:
        """DEFWPT: a user waypoint replaces any earlier one of that name."""
        self.user[name.upper()] = [(lat, lon)]

    def delete(self, name: str) -> bool:
        return self.user.pop(name.upper(), None) is not None

    def clear(self) -> None:
        self.user.clear()

    def lookup(self, name: str, ref_lat: float = 0.0, ref_lon: float = 0.0) -> tuple[float, float] | None:
        """Position of a named place nearest the reference, or None."""
        name = name.upper()
        places = self.user.get(name)
        if places is None and self.use_bluesky_data:
            places = bluesky_navdata().get(name)
        if not places:
            return None
        if len(places) == 1:
            return places[0]
        coslat = math.cos(math.radians(ref_lat))
        return min(places, key=lambda p: (p[0] - ref_lat) ** 2 + ((p[1] - ref_lon) * coslat) ** 2)

    def known(self, name: str) -> bool:
        name = name.upper()
        return name in self.user or (self.use_bluesky_data and name in bluesky_navdata())


def _navdata_dir() -> Path | None:
    spec = importlib.util.find_spec("bluesky")
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(list(spec.submodule_search_locations)[0]) / "resources" / "navdata"
    return path if path.is_dir() else None


@functools.lru_cache(maxsize=1)
def bluesky_navdata() -> NamedPlaces:
    """Airports, navaids and fixes from an installed BlueSky (read once, never modified)."""
    places: NamedPlaces = {}
    folder = _navdata_dir()
    if folder is None:
        return places

    def add(name: str, lat: float, lon: float) -> None:
        places.setdefault(name.upper(), []).append((lat, lon))

    airports = folder / "airports.dat"
    if airports.exists():
        for line in airports.read_text(errors="replace").splitlines():
            if line.startswith("#") or not line.strip():
                continue
            parts = [p.strip() for p in line.split(",")]
            try:
                add(parts[0], float(parts[2]), float(parts[3]))
            except (IndexError, ValueError):
                continue
    fixes = folder / "fix.dat"
    if fixes.exists():
        for line in fixes.read_text(errors="replace").splitlines():
            parts = line.split()
            if len(parts) != 3:
                continue
            try:
                add(parts[2], float(parts[0]), float(parts[1]))
            except ValueError:
                continue
    navaids = folder / "nav.dat"
    if navaids.exists():
        for line in navaids.read_text(errors="replace").splitlines():
            parts = line.split()
            # X-Plane nav.dat: type lat lon elev freq range var ident name...
            if len(parts) < 9 or parts[0] not in ("2", "3", "12", "13"):
                continue
            try:
                add(parts[7], float(parts[1]), float(parts[2]))
            except ValueError:
                continue
    return places
