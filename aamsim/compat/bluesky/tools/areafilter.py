"""BlueSky's ``bluesky.tools.areafilter``: named areas and the test whether points are inside.

The areas are the simulation's shapes (:mod:`aamsim.shapes`), the same ones the
``BOX``/``POLY``/``CIRCLE`` stack commands define, as in BlueSky. Insideness is
BlueSky's (matplotlib's ``Path.contains_points`` for polygons, bounds included
for boxes, ``kwikdist`` for circles) and so is the altitude band (``top`` and
``bottom`` in metres). Differences (docs/bluesky-api.md): area names are not
case-sensitive (aamsim's shapes are upper-case, like its stack commands), and an
unknown shape kind or bad coordinates give ``(False, message)`` instead of
nothing.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from aamsim.compat.bluesky._errors import not_provided
from aamsim.compat.bluesky._state import current_session
from aamsim.errors import CommandError
from aamsim.shapes import UNBOUNDED_BOTTOM_M, UNBOUNDED_TOP_M, Shapes, shapes_of

LOG = logging.getLogger("aamsim.compat.bluesky")


def _shapes(what: str) -> Shapes:
    return shapes_of(current_session(f"bluesky.tools.areafilter.{what}").simulation)


def _kind(shape: str) -> str | None:
    shape = shape.upper()
    if shape in ("BOX", "CIRCLE", "LINE"):
        return shape
    return "POLY" if shape.startswith("POLY") else None


def defineArea(name: str, shape: str, coordinates: Any, top: float = UNBOUNDED_TOP_M,
               bottom: float = UNBOUNDED_BOTTOM_M) -> bool | tuple[bool, str]:
    """Define (or replace) area ``name``: a BOX, CIRCLE, POLY or LINE; coordinates lat, lon, ... [deg, NM].

    ``top``/``bottom`` [m] bound it in altitude. ``name == "LIST"`` lists the areas, and
    no coordinates describes area ``name``, as in BlueSky.
    """
    shapes = _shapes("defineArea")
    if name == "LIST":
        names = shapes.names()
        return True, ("Currently defined shapes:\n" + ", ".join(names)) if names else "No shapes are currently defined."
    if coordinates is None:
        found = shapes.get(name)
        return (True, found.describe()) if found else (False, f"Unknown shape: {name}")
    kind = _kind(shape)
    if kind is None:
        text = f"defineArea {name}: unknown shape {shape} (BOX, CIRCLE, POLY or LINE)"
        LOG.warning("%s", text)
        return False, text
    try:
        shapes.define(name, kind, tuple(float(v) for v in np.ravel(coordinates)), top_m=float(top),
                      bottom_m=float(bottom))
    except CommandError as exc:
        LOG.warning("defineArea: %s", exc.message)
        return False, exc.message
    return True


def checkInside(areaname: str, lat: Any, lon: Any, alt: Any) -> np.ndarray:
    """Which points [deg, deg, m] are inside area ``areaname`` (all False when there is no such area)."""
    return _shapes("checkInside").contains(areaname, np.asarray(lat, dtype=float).reshape(-1),
                                           np.asarray(lon, dtype=float).reshape(-1),
                                           np.asarray(alt, dtype=float).reshape(-1))


def deleteArea(areaname: str) -> None:
    """Delete area ``areaname`` (nothing happens when there is none, as in BlueSky)."""
    _shapes("deleteArea").delete(areaname)


def hasArea(areaname: str) -> bool:
    """Whether area ``areaname`` exists."""
    return areaname in _shapes("hasArea")


def reset() -> None:
    """Delete every area."""
    _shapes("reset").clear()


def __getattr__(name: str) -> Any:
    if name.startswith("__"):
        raise AttributeError(name)
    hints = {"getArea": "BlueSky's shape objects are not provided; checkInside and hasArea are",
             "basic_shapes": "use hasArea and checkInside", "get_intersecting": "needs BlueSky's R-tree",
             "get_knearest": "needs BlueSky's R-tree"}
    raise not_provided(f"bluesky.tools.areafilter.{name}", hints.get(name, ""))
