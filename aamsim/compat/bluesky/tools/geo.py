"""BlueSky's ``bluesky.tools.geo``: bearings, distances and positions.

Same formulas, argument units and return types as BlueSky 1.1.1's Python
implementation (``bluesky/tools/geo/_geo.py``), which is what bluesky-gym gets:
positions in degrees, distances in nautical miles (``latlondist``: metres),
bearings in degrees. The arithmetic is done in the same order, so results are
the same bit for bit (``tests/test_bluesky_api.py`` checks them against BlueSky's).

BlueSky's compiled versions (``_cgeo``, used when ``prefer_compiled`` is on and
``bluesky.tools.geo`` is first imported after ``bluesky.init()``) differ: with
arrays ``kwikqdrdist`` returns the distances alone, and ``kwikdist_matrix`` of
one position against several returns a 1x1 matrix of 0. The shim gives the
Python functions' results (docs/bluesky-api.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aamsim.compat.bluesky._errors import not_provided

nm = 1852.0  # m per nautical mile
_R_KWIK = 6371000.0  # m, the sphere of BlueSky's "kwik" (flat-earth) functions
_WGS84_A = 6378137.0  # m, semi-major axis
_WGS84_B = 6356752.314245  # m, semi-minor axis

Num = Any  # a float, a numpy scalar or an array: the functions broadcast as BlueSky's do


def rwgs84(latd: Num) -> Num:
    """Earth radius [m] of the WGS-84 ellipsoid at latitude ``latd`` [deg] (geocentric)."""
    lat = np.radians(latd)
    coslat, sinlat = np.cos(lat), np.sin(lat)
    an, bn = _WGS84_A * _WGS84_A * coslat, _WGS84_B * _WGS84_B * sinlat
    ad, bd = _WGS84_A * coslat, _WGS84_B * sinlat
    return np.sqrt((an * an + bn * bn) / (ad * ad + bd * bd))


def rwgs84_matrix(latd: Num) -> Num:
    """:func:`rwgs84` of an array or matrix of latitudes [deg]."""
    lat = np.radians(latd)
    coslat, sinlat = np.cos(lat), np.sin(lat)
    an, bn = _WGS84_A * _WGS84_A * coslat, _WGS84_B * _WGS84_B * sinlat
    ad, bd = _WGS84_A * coslat, _WGS84_B * sinlat
    return np.sqrt(np.divide(np.multiply(an, an) + np.multiply(bn, bn), np.multiply(ad, ad) + np.multiply(bd, bd)))


def _mean_radius(latd1: Num, latd2: Num, guard: bool) -> Num:
    """BlueSky's radius for a pair: at the mean latitude, or a weighted one across the equator."""
    same = rwgs84(0.5 * (latd1 + latd2))
    r1, r2 = rwgs84(latd1), rwgs84(latd2)
    weight = abs(latd1) + abs(latd2)
    if guard:
        weight = np.maximum(0.000001, weight)
    across = 0.5 * (abs(latd1) * (r1 + _WGS84_A) + abs(latd2) * (r2 + _WGS84_A)) / weight
    sw = latd1 * latd2 >= 0.0
    return sw * same + (1 - sw) * across


def qdrdist(latd1: Num, lond1: Num, latd2: Num, lond2: Num) -> tuple[Num, Num]:
    """Great-circle bearing [deg, -180..180] and distance [NM] from point 1 to point 2 (WGS-84 radius)."""
    r = _mean_radius(latd1, latd2, guard=True)
    lat1, lon1, lat2, lon2 = np.radians(latd1), np.radians(lond1), np.radians(latd2), np.radians(lond2)
    d = r * np.arccos(np.cos(lat1) * np.cos(lat2) * np.cos(lon2 - lon1) + np.sin(lat1) * np.sin(lat2))
    coslat1, coslat2 = np.cos(lat1), np.cos(lat2)
    qdr = np.degrees(np.arctan2(np.sin(lon2 - lon1) * coslat2,
                                coslat1 * np.sin(lat2) - np.sin(lat1) * coslat2 * np.cos(lon2 - lon1)))
    return qdr, d / nm


def latlondist(latd1: Num, lond1: Num, latd2: Num, lond2: Num) -> Num:
    """Haversine distance [m] (not NM) between two points, WGS-84 radius."""
    r = _mean_radius(latd1, latd2, guard=False)
    lat1, lon1, lat2, lon2 = np.radians(latd1), np.radians(lond1), np.radians(latd2), np.radians(lond2)
    sin1, sin2 = np.sin(0.5 * (lat2 - lat1)), np.sin(0.5 * (lon2 - lon1))
    root = sin1 * sin1 + np.cos(lat1) * np.cos(lat2) * sin2 * sin2
    return 2.0 * r * np.arctan2(np.sqrt(root), np.sqrt(1.0 - root))


def wgsg(latd: Num) -> Num:
    """Gravity [m/s^2] at latitude ``latd`` [deg] (WGS-84)."""
    sinlat = np.sin(np.radians(latd))
    return 9.7803 * (1.0 + 0.001932 * sinlat * sinlat) / np.sqrt(1.0 - 6.694e-3 * sinlat * sinlat)


def qdrpos(latd1: Num, lond1: Num, qdr: Num, dist: Num) -> tuple[Num, Num]:
    """The point [deg] at bearing ``qdr`` [deg] and distance ``dist`` [NM] from point 1 (WGS-84 radius)."""
    rnm = rwgs84(latd1) / nm
    lat1, lon1 = np.radians(latd1), np.radians(lond1)
    lat2 = np.arcsin(np.sin(lat1) * np.cos(dist / rnm) + np.cos(lat1) * np.sin(dist / rnm) * np.cos(np.radians(qdr)))
    lon2 = lon1 + np.arctan2(np.sin(np.radians(qdr)) * np.sin(dist / rnm) * np.cos(lat1),
                             np.cos(dist / rnm) - np.sin(lat1) * np.sin(lat2))
    return np.degrees(lat2), np.degrees(lon2)


def _kwik(dlat_deg: Num, dlon_deg: Num, sumlat_deg: Num) -> tuple[Num, Num, Num]:
    """Flat-earth differences: (dlat [rad], dlon [rad, wrapped to -180..180 deg], cos of the mean latitude)."""
    dlat = np.radians(dlat_deg)
    dlon = np.radians(((dlon_deg) + 180) % 360 - 180)
    cavelat = np.cos(np.radians(sumlat_deg) * 0.5)
    return dlat, dlon, cavelat


def _kwik_dist(dlat: Num, dlon: Num, cavelat: Num) -> Num:
    dangle = np.sqrt(dlat * dlat + dlon * dlon * cavelat * cavelat)
    return _R_KWIK * dangle / nm


def kwikdist(lata: Num, lona: Num, latb: Num, lonb: Num) -> Num:
    """Flat-earth distance [NM] from a to b (6371 km sphere); fine for short distances away from the poles."""
    return _kwik_dist(*_kwik(latb - lata, lonb - lona, lata + latb))


def kwikqdrdist(lata: Num, lona: Num, latb: Num, lonb: Num) -> tuple[Num, Num]:
    """Flat-earth bearing [deg, 0..360) and distance [NM] from a to b."""
    dlat, dlon, cavelat = _kwik(latb - lata, lonb - lona, lata + latb)
    return np.degrees(np.arctan2(dlon * cavelat, dlat)) % 360.0, _kwik_dist(dlat, dlon, cavelat)


def _t(x: Num) -> Num:
    """Transpose as BlueSky's ``.T`` (matrices and arrays; a scalar stays a scalar)."""
    return x.T if hasattr(x, "T") else np.transpose(x)


def kwikdist_matrix(lata: Num, lona: Num, latb: Num, lonb: Num) -> Num:
    """:func:`kwikdist` for matrices (column against row vectors give every pair) or arrays (element-wise)."""
    dlat, dlon, cavelat = _kwik(latb - _t(lata), lonb - _t(lona), lata + _t(latb))
    return _R_KWIK * np.sqrt(np.multiply(dlat, dlat) + np.multiply(np.multiply(dlon, dlon),
                                                                    np.multiply(cavelat, cavelat))) / nm


def kwikqdrdist_matrix(lata: Num, lona: Num, latb: Num, lonb: Num) -> tuple[Num, Num]:
    """:func:`kwikqdrdist` for matrices or arrays, as :func:`kwikdist_matrix`."""
    dlat, dlon, cavelat = _kwik(latb - _t(lata), lonb - _t(lona), latb + _t(lata))
    dist = _R_KWIK * np.sqrt(np.multiply(dlat, dlat) + np.multiply(np.multiply(dlon, dlon),
                                                                    np.multiply(cavelat, cavelat))) / nm
    return np.degrees(np.arctan2(np.multiply(dlon, cavelat), dlat)) % 360.0, dist


def kwikpos(latd1: Num, lond1: Num, qdr: Num, dist: Num) -> tuple[Num, Num]:
    """Flat-earth position [deg] at bearing ``qdr`` [deg] and distance ``dist`` [NM] from point 1."""
    dx = dist * np.sin(np.radians(qdr))
    dy = dist * np.cos(np.radians(qdr))
    latd2 = latd1 + dy / 60.0
    lond2 = ((lond1 + dx / np.maximum(0.01, 60.0 * np.cos(np.radians(latd1)))) + 180) % 360 - 180
    return latd2, lond2


def __getattr__(name: str) -> Any:
    if name.startswith("__"):
        raise AttributeError(name)
    hints = {"magdec": "the magnetic variation table is not shipped", "magdeccmd": "MAGVAR is not a command",
             "qdrdist_matrix": "use qdrdist with arrays", "latlondist_matrix": "use latlondist with arrays"}
    raise not_provided(f"bluesky.tools.geo.{name}", hints.get(name, ""))
