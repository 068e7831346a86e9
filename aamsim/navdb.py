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
# Airport -> runway -> (threshold lat [deg], lon [deg], runway bearing [deg]).
Runways = dict[str, dict[str, tuple[float, float, float]]]
_EARTH_RADIUS_INV = 1.56961231e-7  # 1/m: BlueSky's constant for the displaced thresholds (1 / 6371 km)


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
        if "/RW" in name:
            return self.runway(name) is not None
        return name in self.user or (self.use_bluesky_data and name in bluesky_navdata())

    def is_airport(self, name: str) -> bool:
        """Whether ``name`` is an airport of the navigation data (``EHAM RW18C`` is then a runway)."""
        return self.use_bluesky_data and name.upper() in bluesky_airports()

    def runway(self, name: str) -> tuple[float, float, float] | None:
        """Threshold of ``APT/RWxx`` (or ``APT/RWYxx``): lat, lon [deg] and runway bearing [deg], or None."""
        if not self.use_bluesky_data or "/RW" not in name.upper():
            return None
        airport, runway = name.upper().split("/RW", 1)
        return bluesky_runways().get(airport, {}).get(runway.lstrip("Y"))


def navdata_dir() -> Path | None:
    """The navigation-data folder of an installed BlueSky (bluesky-simulator), or None."""
    spec = importlib.util.find_spec("bluesky")
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(list(spec.submodule_search_locations)[0]) / "resources" / "navdata"
    return path if path.is_dir() else None


@functools.lru_cache(maxsize=1)
def bluesky_navdata() -> NamedPlaces:
    """Airports, navaids and fixes from an installed BlueSky (read once, never modified)."""
    places: NamedPlaces = {}
    folder = navdata_dir()
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


@functools.lru_cache(maxsize=1)
def bluesky_airports() -> frozenset[str]:
    """Codes of the airports in BlueSky's airports.dat."""
    folder = navdata_dir()
    if folder is None or not (folder / "airports.dat").exists():
        return frozenset()
    codes = set()
    for line in (folder / "airports.dat").read_text(errors="replace").splitlines():
        if line.strip() and not line.startswith("#"):
            codes.add(line.split(",", 1)[0].strip().upper())
    return frozenset(codes)


@functools.lru_cache(maxsize=1)
def bluesky_runways() -> Runways:
    """Runway thresholds from BlueSky's apt.zip (X-Plane apt.dat), read on first use (about 2 s of CPU).

    As BlueSky reads them: land runways (row code 100) with a hard surface (code 1 or 2);
    each row gives both ends. The threshold is the runway end moved along the runway by its
    displaced-threshold length, on a sphere; the bearing is the initial great-circle course
    from this end to the other.
    """
    runways: Runways = {}
    folder = navdata_dir()
    if folder is None or not (folder / "apt.zip").exists():
        return runways
    import zipfile

    current: dict[str, tuple[float, float, float]] | None = None
    with zipfile.ZipFile(folder / "apt.zip") as archive, archive.open("apt.dat") as fh:
        for raw in fh:
            if raw[:2] == b"1 ":
                elems = raw.decode("ascii", errors="ignore").split()
                current = runways.setdefault(elems[4].upper(), {}) if len(elems) > 4 else None
            elif raw[:4] == b"100 " and current is not None:
                elems = raw.decode("ascii", errors="ignore").split()
                try:
                    if int(elems[2]) > 2:
                        continue
                    lat0, lon0, off0 = float(elems[9]), float(elems[10]), float(elems[11])
                    lat1, lon1, off1 = float(elems[18]), float(elems[19]), float(elems[20])
                except (IndexError, ValueError):
                    continue
                current[elems[8].upper()] = _threshold(lat0, lon0, lat1, lon1, off0)
                current[elems[17].upper()] = _threshold(lat1, lon1, lat0, lon0, off1)
    return runways


def _threshold(lat1: float, lon1: float, lat2: float, lon2: float, offset_m: float) -> tuple[float, float, float]:
    """Runway end 1 moved ``offset_m`` towards end 2 on the sphere; (lat, lon, bearing) in degrees."""
    p1, p2, dl = math.radians(lat1), math.radians(lat2), math.radians(lon2 - lon1)
    bearing = math.atan2(math.sin(dl) * math.cos(p2), math.cos(p1) * math.sin(p2) - math.sin(p1) * math.cos(p2) *
                         math.cos(dl))
    bearing = math.radians((math.degrees(bearing) + 360.0) % 360.0)
    d = offset_m * _EARTH_RADIUS_INV
    lat = math.asin(math.sin(p1) * math.cos(d) + math.cos(p1) * math.sin(d) * math.cos(bearing))
    lon = math.radians(lon1) + math.atan2(math.sin(bearing) * math.sin(d) * math.cos(p1),
                                          math.cos(d) - math.sin(p1) * math.sin(lat))
    return math.degrees(lat), math.degrees(lon), math.degrees(bearing)
