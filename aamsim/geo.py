"""Geodesy: bearings, distances and position updates (degrees, metres).

Three levels of accuracy, each used where BlueSky uses it so that
trajectories agree with a BlueSky run:

* guidance (bearing and distance to the active waypoint): a spherical
  great-circle formula on the local WGS-84 radius (:func:`qdrdist_scalar`);
* conflict detection: the equirectangular approximation
  (:func:`kwik_qdrdist`), fast and accurate to well under 0.1 % at the
  tens-of-kilometres scale of a conflict;
* reporting and scenario generation: the exact WGS-84 geodesic from pyproj
  (:func:`geodesic_inverse`, :func:`geodesic_forward`).

The position update itself is BlueSky's flat-earth Euler step on a 6371 km
sphere (see ``docs/bluesky-differences.md`` for its error against WGS-84).
"""

from __future__ import annotations

import math
from functools import cache
from typing import TYPE_CHECKING

import numpy as np

from aamsim.numba_cache import njit
from aamsim.units import NM, R_EARTH

WGS84_A = 6378137.0  # m, semi-major axis
WGS84_B = 6356752.314245  # m, semi-minor axis

if TYPE_CHECKING:
    from pyproj import Geod


@cache
def _wgs84() -> Geod:
    """pyproj's WGS-84 geodesic, created at its first use (importing pyproj costs every start 25 ms)."""
    from pyproj import Geod

    return Geod(ellps="WGS84")


@njit(cache=True, inline="always")
def wgs84_radius(lat_deg: float) -> float:
    """Earth radius [m] at a latitude on the WGS-84 ellipsoid."""
    lat = math.radians(lat_deg)
    coslat = math.cos(lat)
    sinlat = math.sin(lat)
    an = WGS84_A * WGS84_A * coslat
    bn = WGS84_B * WGS84_B * sinlat
    ad = WGS84_A * coslat
    bd = WGS84_B * sinlat
    return math.sqrt((an * an + bn * bn) / (ad * ad + bd * bd))


@njit(cache=True)
def qdrdist_scalar(lat1: float, lon1: float, lat2: float, lon2: float) -> tuple[float, float]:
    """Bearing [deg, -180..180] and distance [m] from point 1 to point 2.

    Great circle on a sphere whose radius is the WGS-84 radius at the mean
    latitude (a blend of both radii across the equator).
    """
    if lat1 * lat2 >= 0.0:
        r = wgs84_radius(0.5 * (lat1 + lat2))
    else:
        r1 = wgs84_radius(lat1)
        r2 = wgs84_radius(lat2)
        r = 0.5 * (abs(lat1) * (r1 + WGS84_A) + abs(lat2) * (r2 + WGS84_A)) / max(
            0.000001, abs(lat1) + abs(lat2)
        )
    la1 = math.radians(lat1)
    la2 = math.radians(lat2)
    dlon = math.radians(lon2) - math.radians(lon1)
    cosarg = math.cos(la1) * math.cos(la2) * math.cos(dlon) + math.sin(la1) * math.sin(la2)
    # Rounding can push the argument a hair over 1 for coincident points.
    cosarg = min(1.0, max(-1.0, cosarg))
    dist = r * math.acos(cosarg)
    qdr = math.degrees(
        math.atan2(
            math.sin(dlon) * math.cos(la2),
            math.cos(la1) * math.sin(la2) - math.sin(la1) * math.cos(la2) * math.cos(dlon),
        )
    )
    return qdr, dist


def qdrdist(lat1: float, lon1: float, lat2: float, lon2: float) -> tuple[float, float]:
    """Python-side wrapper of :func:`qdrdist_scalar`: (bearing deg, distance m)."""
    return qdrdist_scalar(float(lat1), float(lon1), float(lat2), float(lon2))


@njit(cache=True, inline="always")
def degto180(angle: float) -> float:
    """Wrap an angle difference to [-180, 180) degrees."""
    return (angle + 180.0) % 360.0 - 180.0


def kwik_qdrdist(
    lat1: np.ndarray, lon1: np.ndarray, lat2: np.ndarray, lon2: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Equirectangular bearing [deg, 0..360) and distance [m] (vectorised)."""
    dlat = np.radians(lat2 - lat1)
    dlon = np.radians((lon2 - lon1 + 180.0) % 360.0 - 180.0)
    cavelat = np.cos(np.radians(lat1 + lat2) * 0.5)
    dist = R_EARTH * np.sqrt(dlat * dlat + dlon * dlon * cavelat * cavelat)
    qdr = np.degrees(np.arctan2(dlon * cavelat, dlat)) % 360.0
    return qdr, dist


def geodesic_inverse(lat1: float, lon1: float, lat2: float, lon2: float) -> tuple[float, float]:
    """Exact WGS-84 forward azimuth [deg] and distance [m] (pyproj)."""
    az, _, dist = _wgs84().inv(lon1, lat1, lon2, lat2)
    return float(az), float(dist)


def geodesic_forward(lat: float, lon: float, azimuth_deg: float, dist_m: float) -> tuple[float, float]:
    """Exact WGS-84 destination point (lat, lon) [deg] (pyproj)."""
    lon2, lat2, _ = _wgs84().fwd(lon, lat, azimuth_deg, dist_m)
    return float(lat2), float(lon2)


def geodesic_path_length(lats: np.ndarray, lons: np.ndarray) -> float:
    """Length [m] of a polyline on the WGS-84 ellipsoid (pyproj)."""
    if len(lats) < 2:
        return 0.0
    return float(_wgs84().line_length(np.asarray(lons, dtype=float), np.asarray(lats, dtype=float)))


def destination_flat(lat: float, lon: float, bearing_deg: float, dist_m: float) -> tuple[float, float]:
    """Flat-earth destination point, the inverse of :func:`kwik_qdrdist` (small distances)."""
    dx = dist_m * math.sin(math.radians(bearing_deg))
    dy = dist_m * math.cos(math.radians(bearing_deg))
    dlat = math.degrees(dy / R_EARTH)
    dlon = math.degrees(dx / (R_EARTH * max(0.01, math.cos(math.radians(lat)))))
    return lat + dlat, (lon + dlon + 180.0) % 360.0 - 180.0


__all__ = [
    "NM",
    "degto180",
    "destination_flat",
    "geodesic_forward",
    "geodesic_inverse",
    "geodesic_path_length",
    "kwik_qdrdist",
    "qdrdist",
    "qdrdist_scalar",
    "wgs84_radius",
]
