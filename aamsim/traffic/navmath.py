"""Navigation arithmetic of the step kernel: bearings, distances, position steps.

These are BlueSky's formulas, evaluated cheaply. The per-step cost of the
traffic update is mostly trigonometry, so the kernel avoids libm where it can
without changing the result beyond a few units in the last place:

* **Guidance** (bearing and distance to the active waypoint) is BlueSky's
  great circle on the local WGS-84 radius (:func:`aamsim.geo.qdrdist_scalar`).
  * The waypoint's sine and cosine are cached per leg. The aircraft's come
    from the position update.
  * For longitude differences under 0.05 rad, sine and cosine are Taylor
    series. So is the arcsine for chords under a 250 km distance. Each series
    is truncated where its first omitted term is below 1e-19 relative, which
    is exact to double precision.
  * The central angle comes from the chord between the two points. This is
    the same great circle as BlueSky's ``acos(sin sin + cos cos cos)``, but
    it keeps full precision close to the waypoint.
  * The bearing is an anchor bearing from libm's ``atan2`` plus the small angle
    to the current direction, from an arctangent series. libm runs again only
    when the bearing has turned by more than 0.57 deg.
  * The heading cache receives the bearing's sine and cosine from the same
    triangle, because the aircraft usually flies exactly that bearing next
    step.
* **Position update:** BlueSky's flat-earth forward Euler step on a 6371 km
  sphere. cos(lat) for the longitude step, and sin(lat) for the guidance, are
  rotated from the exact values at an anchor latitude within 1.3 km. This is
  exact to a few ulps and builds up no error.

The trajectories agree with BlueSky's to a third of a millimetre over 15 minutes (see
``docs/bluesky-differences.md``). Every cache is keyed by the value it was
computed from, so a command that moves an aircraft cannot leave a stale one.
"""

from __future__ import annotations

import math

import numpy as np

from aamsim.geo import WGS84_A, WGS84_B, qdrdist_scalar
from aamsim.numba_cache import njit
from aamsim.traffic.fields import (
    C_COSHDG,
    C_COSLA0,
    C_HDG,
    C_LA0,
    C_LAT,
    C_Q0,
    C_Q0COS,
    C_Q0SIN,
    C_SINHDG,
    C_SINLA0,
    C_SINLAT,
    C_WPCOS,
    C_WPLAT,
    C_WPSIN,
    COSLAT,
    HDG,
    LAT,
    LON,
    WP_LAT,
    WP_LON,
)
from aamsim.units import R_EARTH

_A2 = WGS84_A * WGS84_A
_B2 = WGS84_B * WGS84_B
_A4 = _A2 * _A2
_B4 = _B2 * _B2
_INV_R_EARTH = 1.0 / R_EARTH
_MIN_COSLAT = math.cos(math.radians(89.999))  # east-west steps near a pole stay finite
# Domains of the series (first omitted term under 1e-19 relative).
_SMALL_DLON = 0.05  # rad, longitude difference to the waypoint
_SMALL_CHORD = 0.02  # half chord of the unit sphere (a 250 km distance)
_SMALL_DLAT = 2e-4  # rad (1.3 km) from the anchor latitude of the position update
_SMALL_DQDR = 0.01  # tangent of the bearing change from the anchor bearing (0.57 deg)
# Series coefficients (multiplications: a division by a literal is not folded).
_S3, _S5, _S7, _S9 = -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0  # sin x / x
_C4, _C6, _C8 = -1.0 / 24.0, 1.0 / 720.0, -1.0 / 40320.0  # (1 - cos x) / x^2 beyond 1/2
_AS3, _AS5, _AS7, _AS9 = 1.0 / 6.0, 3.0 / 40.0, 5.0 / 112.0, 35.0 / 1152.0  # asin x / x
_AT3, _AT5, _AT7 = -1.0 / 3.0, 1.0 / 5.0, -1.0 / 7.0  # atan x / x


@njit(cache=True, inline="always")
def wrap360(x: float) -> float:
    """``x % 360.0`` with Python semantics; cheap in the common in-range case."""
    if 0.0 <= x < 360.0:
        return x
    if -360.0 <= x < 0.0:
        return x + 360.0
    if 360.0 <= x < 720.0:
        return x - 360.0
    return x % 360.0


@njit(cache=True, inline="always")
def wrap180(x: float) -> float:
    """Angle difference wrapped to [-180, 180) degrees (``(x + 180) % 360 - 180``)."""
    return wrap360(x + 180.0) - 180.0


@njit(cache=True, inline="always")
def guidance(F: np.ndarray, i: int) -> tuple[float, float]:
    """Bearing [deg, any turn of 360] and distance [m] from aircraft ``i`` to its active waypoint.

    BlueSky's great circle on the WGS-84 radius at the mean latitude (see the
    module docstring for how it is evaluated).
    """
    lat1 = F[LAT, i]
    lat2 = F[WP_LAT, i]
    if F[C_WPLAT, i] != lat2:
        la2 = math.radians(lat2)
        F[C_WPSIN, i] = math.sin(la2)
        F[C_WPCOS, i] = math.cos(la2)
        F[C_WPLAT, i] = lat2
    s2 = F[C_WPSIN, i]
    c2 = F[C_WPCOS, i]
    # sin(lat) comes with cos(lat) from the position update.
    s1 = F[C_SINLAT, i] if F[C_LAT, i] == lat1 else math.sin(math.radians(lat1))
    c1 = F[COSLAT, i]
    if lat1 * lat2 >= 0.0:
        # sin^2 of the mean latitude from the two points' sines and cosines.
        smean2 = 0.5 * (1.0 - (c1 * c2 - s1 * s2))
        cmean2 = 1.0 - smean2
        r = math.sqrt((_A4 * cmean2 + _B4 * smean2) / (_A2 * cmean2 + _B2 * smean2))
    else:
        return qdrdist_scalar(lat1, F[LON, i], lat2, F[WP_LON, i])
    dlon = math.radians(F[WP_LON, i]) - math.radians(F[LON, i])
    if abs(dlon) < _SMALL_DLON:
        # The series also give 1 - cos(dlon) without cancellation.
        x2 = dlon * dlon
        sdl = dlon * (1.0 + x2 * (_S3 + x2 * (_S5 + x2 * (_S7 + x2 * _S9))))
        one_minus_cdl = x2 * (0.5 + x2 * (_C4 + x2 * (_C6 + x2 * _C8)))
        cdl = 1.0 - one_minus_cdl
    else:
        cdl = math.cos(dlon)
        sdl = math.sin(dlon)
        one_minus_cdl = 1.0 - cdl
    # Central angle from the chord between the two points on the unit sphere:
    # the same great circle as BlueSky's acos(sin sin + cos cos cos), without
    # its loss of precision at short range.
    ds = s1 - s2
    dc = c1 - c2
    half_chord = 0.5 * math.sqrt(ds * ds + dc * dc + 2.0 * c1 * c2 * one_minus_cdl)
    if half_chord < _SMALL_CHORD:
        h2 = half_chord * half_chord
        angle = 2.0 * half_chord * (
            1.0 + h2 * (_AS3 + h2 * (_AS5 + h2 * (_AS7 + h2 * _AS9)))
        )
    else:
        angle = 2.0 * math.asin(min(1.0, half_chord))
    dist = r * angle
    y = sdl * c2
    x = c1 * s2 - s1 * c2 * cdl
    h2 = x * x + y * y
    if h2 > 0.0:
        inv = 1.0 / math.sqrt(h2)
        cq = x * inv
        sq = y * inv
        # The anchor bearing plus the small angle between the two directions.
        c0 = F[C_Q0COS, i]
        s0 = F[C_Q0SIN, i]
        dot = c0 * cq + s0 * sq
        crs = c0 * sq - s0 * cq
        if dot > 0.0 and abs(crs) < _SMALL_DQDR * dot:
            t = crs / dot
            t2 = t * t
            qdr = F[C_Q0, i] + math.degrees(t * (1.0 + t2 * (_AT3 + t2 * (_AT5 + t2 * _AT7))))
        else:
            qdr = math.degrees(math.atan2(y, x))
            F[C_Q0, i] = qdr
            F[C_Q0COS, i] = cq
            F[C_Q0SIN, i] = sq
        # The aircraft usually flies exactly this bearing next step: give the
        # heading cache its sine and cosine from the same triangle.
        F[C_HDG, i] = wrap360(qdr)
        F[C_SINHDG, i] = sq
        F[C_COSHDG, i] = cq
    else:
        qdr = math.degrees(math.atan2(y, x))
    return qdr, dist



@njit(cache=True, inline="always")
def position_step(F: np.ndarray, i: int, dt: float, gsn: float, gse: float) -> None:
    """BlueSky's flat-earth Euler step of aircraft ``i`` [ground speed north/east, m/s].

    Unlike BlueSky, longitude stays in [-180, 180) and an aircraft flying over a
    pole comes down the other side of it: latitude reflects, longitude turns by
    180 deg and so does the heading (the great circle through the pole). East-west
    motion near a pole is computed with cos(lat) no smaller than cos(89.999 deg),
    so that an aircraft at the pole heading east stays finite (it reached a
    longitude of 2.34e16 deg before).
    """
    if gsn != 0.0:
        lat = F[LAT, i] + math.degrees(dt * gsn * _INV_R_EARTH)
        if lat > 90.0 or lat < -90.0:
            lat = (180.0 if lat > 0.0 else -180.0) - lat
            F[LON, i] = F[LON, i] + 180.0
            F[HDG, i] = (F[HDG, i] + 180.0) % 360.0
            F[C_HDG, i] = math.nan  # the heading's sine and cosine are recomputed
            F[C_LA0, i] = math.inf  # the anchor is far: sine and cosine of lat computed afresh
        F[LAT, i] = lat
        la = math.radians(lat)
        d = la - F[C_LA0, i]
        if abs(d) < _SMALL_DLAT:
            # Rotate the anchor's exact sine and cosine by d.
            d2 = d * d
            cd = 1.0 - d2 * (0.5 + d2 * _C4)
            sd = d * (1.0 + d2 * (_S3 + d2 * _S5))
            s0 = F[C_SINLA0, i]
            c0 = F[C_COSLA0, i]
            F[COSLAT, i] = c0 * cd - s0 * sd
            F[C_SINLAT, i] = s0 * cd + c0 * sd
        else:
            c0 = math.cos(la)
            s0 = math.sin(la)
            F[C_LA0, i] = la
            F[C_SINLA0, i] = s0
            F[C_COSLA0, i] = c0
            F[COSLAT, i] = c0
            F[C_SINLAT, i] = s0
        F[C_LAT, i] = lat
    lon = F[LON, i] + math.degrees(dt * gse * _INV_R_EARTH / max(F[COSLAT, i], _MIN_COSLAT))
    if lon >= 180.0 or lon < -180.0:
        lon = (lon + 180.0) % 360.0 - 180.0
    F[LON, i] = lon
