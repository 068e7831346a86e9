"""Coastlines for the map, from an installed BlueSky (``bluesky-simulator``), read at run time.

BlueSky's radar display draws the world's coastlines from its navigation data
(``resources/navdata/coastlines.dat``: ``M lat lon`` starts a line, ``D lat lon``
continues it; about 0.05 deg resolution). The paper's figure of New York
traffic is that display, so the viewer draws the same lines when BlueSky is
installed (the ``test`` extra installs it). Nothing of BlueSky's is copied into
aamsim; without BlueSky the map has no coastline.
"""

from __future__ import annotations

import functools

import numpy as np

from aamsim.navdb import navdata_dir


@functools.lru_cache(maxsize=1)
def _all_lines() -> tuple[np.ndarray, ...]:
    folder = navdata_dir()
    path = None if folder is None else folder / "coastlines.dat"
    if path is None or not path.is_file():
        return ()
    lines: list[np.ndarray] = []
    current: list[tuple[float, float]] = []
    with open(path, encoding="utf-8", errors="replace") as fh:
        for raw in fh:
            parts = raw.split()
            if len(parts) < 3 or parts[0] not in ("M", "D"):
                continue
            try:
                point = (float(parts[1]), float(parts[2]))
            except ValueError:
                continue
            if parts[0] == "M" and current:
                if len(current) > 1:
                    lines.append(np.array(current))
                current = []
            current.append(point)
    if len(current) > 1:
        lines.append(np.array(current))
    return tuple(lines)


def coastlines(bounds: tuple[float, float, float, float], margin_deg: float = 0.1) -> tuple[np.ndarray, ...]:
    """The coastline pieces (``(k, 2)`` lat/lon) with a point within ``bounds`` widened by ``margin_deg``."""
    lat0, lat1, lon0, lon1 = bounds
    lat0, lat1, lon0, lon1 = lat0 - margin_deg, lat1 + margin_deg, lon0 - margin_deg, lon1 + margin_deg
    out = []
    for line in _all_lines():
        inside = (line[:, 0] >= lat0) & (line[:, 0] <= lat1) & (line[:, 1] >= lon0) & (line[:, 1] <= lon1)
        if not inside.any():
            continue
        # keep the inside run plus one point either side, so the line reaches the map's edge
        idx = np.flatnonzero(inside)
        lo, hi = max(int(idx[0]) - 1, 0), min(int(idx[-1]) + 2, len(line))
        out.append(line[lo:hi])
    return tuple(out)
