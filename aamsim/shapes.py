"""Named shapes (BlueSky's ``areafilter``): BOX, CIRCLE, POLY, POLYALT, LINE and POLYLINE.

A shape is an area in latitude/longitude with an altitude band; the deletion
area (``AREA``), the experiment area (``EXP``) and geovectors (``GEOVECTOR``)
refer to shapes by name, and ``DEL name`` removes one. Each simulation keeps
its own :class:`Shapes` (``shapes_of(sim)``); a reset clears them, as
BlueSky's does.

Insideness is BlueSky's, so that the same aircraft are found inside:

* box: corner latitudes and longitudes, bounds included;
* circle: BlueSky's flat-earth ``kwikdist`` from the centre (6371 km sphere,
  cosine of the mean latitude), radius in nautical miles, bound included;
* polygon: matplotlib's ``Path.contains_points`` on (lat, lon) pairs, the
  function BlueSky calls;
* line: nothing is inside a line;

and the altitude within ``[bottom, top]`` (metres; by default unbounded).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.errors import CommandError
from aamsim.units import NM, R_EARTH

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

UNBOUNDED_TOP_M = 1e9  # BlueSky's defaults: no altitude limit
UNBOUNDED_BOTTOM_M = -1e9


@dataclass
class Shape:
    """A named area: ``kind`` is BOX, CIRCLE, POLY or LINE; ``coordinates`` as given (lat, lon, ...)."""

    name: str
    kind: str
    coordinates: tuple[float, ...]
    top_m: float = UNBOUNDED_TOP_M
    bottom_m: float = UNBOUNDED_BOTTOM_M
    _path: Any = field(default=None, repr=False)

    def __post_init__(self) -> None:
        # The band is ordered whichever way it was given (BlueSky: top = max, bottom = min).
        self.top_m, self.bottom_m = max(self.top_m, self.bottom_m), min(self.top_m, self.bottom_m)
        if self.kind == "POLY":
            from matplotlib.path import Path  # imported when a polygon is first defined (0.1 s)

            self._path = Path(np.reshape(np.asarray(self.coordinates, dtype=float), (-1, 2)))

    def contains(self, lat: np.ndarray, lon: np.ndarray, alt: np.ndarray) -> np.ndarray:
        """Boolean array: which of the points [deg, deg, m] are inside."""
        lat, lon, alt = np.asarray(lat, float), np.asarray(lon, float), np.asarray(alt, float)
        in_band = (self.bottom_m <= alt) & (alt <= self.top_m)
        c = self.coordinates
        if self.kind == "BOX":
            lat0, lat1 = min(c[0], c[2]), max(c[0], c[2])
            lon0, lon1 = min(c[1], c[3]), max(c[1], c[3])
            return (lat0 <= lat) & (lat <= lat1) & (lon0 <= lon) & (lon <= lon1) & in_band
        if self.kind == "CIRCLE":
            return (kwikdist_nm(c[0], c[1], lat, lon) <= c[2]) & in_band
        if self.kind == "POLY":
            if not len(lat):
                return np.zeros(0, dtype=bool)
            # Filled in place: np.column_stack costs several times more than the test itself for the
            # one or few points of a call (bluesky-gym tests one aircraft against ten areas every step).
            points = np.empty((lat.shape[0], 2))
            points[:, 0] = lat
            points[:, 1] = lon
            return self._path.contains_points(points) & in_band
        return np.zeros(lat.shape, dtype=bool)

    def describe(self) -> str:
        band = ""
        if self.top_m < 9e8 or self.bottom_m > -9e8:
            band = f", altitude {self.bottom_m:g} .. {self.top_m:g} m"
        return f"{self.name}: {self.kind} {', '.join(f'{v:g}' for v in self.coordinates)}{band}"


def kwikdist_nm(lat_a: float, lon_a: float, lat_b: np.ndarray, lon_b: np.ndarray) -> np.ndarray:
    """BlueSky's quick flat-earth distance [NM] (6371 km sphere, cosine of the mean latitude)."""
    dlat = np.radians(lat_b - lat_a)
    dlon = np.radians(((lon_b - lon_a) + 180.0) % 360.0 - 180.0)
    cavelat = np.cos(np.radians(lat_a + lat_b) * 0.5)
    return R_EARTH * np.sqrt(dlat * dlat + dlon * dlon * cavelat * cavelat) / NM


class Shapes:
    """The named shapes of one simulation."""

    def __init__(self) -> None:
        self._shapes: dict[str, Shape] = {}

    def define(self, name: str, kind: str, coordinates: tuple[float, ...], top_m: float | None = None,
               bottom_m: float | None = None) -> Shape:
        """Define (or replace) a shape; the coordinates are checked for the kind."""
        name = name.upper()
        if not name:
            raise CommandError(f"{kind} needs a name")
        need = {"BOX": 4, "CIRCLE": 3}.get(kind)
        if need is not None and len(coordinates) != need:
            raise CommandError(f"{kind} {name} needs {need} numbers, not {len(coordinates)}")
        if kind in ("POLY", "LINE") and (len(coordinates) < 4 or len(coordinates) % 2):
            raise CommandError(f"{kind} {name} needs at least two lat,lon points")
        if kind == "POLY" and len(coordinates) < 6:
            raise CommandError(f"polygon {name} needs at least three lat,lon points")
        if kind == "CIRCLE" and not (math.isfinite(coordinates[2]) and coordinates[2] >= 0):
            raise CommandError(f"circle {name}: radius {coordinates[2]:g} nm is not a distance")
        top = UNBOUNDED_TOP_M if top_m is None else top_m
        bottom = UNBOUNDED_BOTTOM_M if bottom_m is None else bottom_m
        shape = Shape(name, kind, tuple(float(v) for v in coordinates), top, bottom)
        self._shapes[name] = shape
        return shape

    def get(self, name: str) -> Shape | None:
        return self._shapes.get(name.upper())

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name.upper() in self._shapes

    def delete(self, name: str) -> bool:
        return self._shapes.pop(name.upper(), None) is not None

    def names(self) -> list[str]:
        return list(self._shapes)

    def contains(self, name: str, lat: np.ndarray, lon: np.ndarray, alt: np.ndarray) -> np.ndarray:
        """Inside the named shape (all False when there is no such shape, as in BlueSky)."""
        shape = self._shapes.get(name.upper())
        if shape is None:
            return np.zeros(len(lat), dtype=bool)
        return shape.contains(lat, lon, alt)

    def clear(self) -> None:
        self._shapes.clear()


def shapes_of(sim: CommandContext) -> Shapes:
    """The simulation's shapes (created on first use; a reset clears them)."""
    shapes = sim.features.get(Shapes)
    if shapes is None:
        shapes = sim.features.add(Shapes())
        sim.hooks.reset.add(lambda s: shapes.clear(), name="shapes-reset")
    return shapes


def delete_shape(sim: CommandContext, name: str) -> bool:
    """Remove a shape by name (BlueSky's DEL shapename); False when there is none."""
    shapes = sim.features.get(Shapes)
    return bool(shapes is not None and shapes.delete(name))
