"""The wind field: wind vectors defined at points, interpolated as BlueSky does.

BlueSky's ``WIND lat,lon,dir,spd`` defines the wind at one point, the same at
every altitude; ``WIND lat,lon,alt,dir,spd,alt,dir,spd,...`` defines a profile
over altitude there. A field is:

* **empty** (``dim`` 0): no wind;
* **one point without a profile** (``dim`` 1): that wind everywhere;
* **several points, none with a profile** (``dim`` 2): horizontal
  interpolation;
* **any point with a profile** (``dim`` 3): horizontal and vertical.

The horizontal interpolation is BlueSky's inverse distance squared: the
weight of point k is ``1 / (dx^2 + dy^2 + 1e-20)`` with ``dy`` the latitude
difference and ``dx`` the longitude difference times the cosine of the mean
latitude, both in degrees. Each point's profile is tabulated on a fixed axis
from 0 to 45,000 ft in steps of 100 ft (linear between the given altitudes,
constant beyond them); the wind at an altitude is linear between the two
table rows around it. A point without a profile has the same value in every
row.

The step kernel evaluates :func:`wind_at` for every aircraft at every step,
from the arrays of :meth:`WindField.arrays`, exactly as BlueSky evaluates its
field in every update: the wind moves the aircraft (ground speed = TAS vector
+ wind, above 50 ft) and the autopilot flies the heading that makes good the
desired track.
"""

from __future__ import annotations

import math

import numpy as np

from aamsim.numba_cache import njit
from aamsim.units import FT

ALT_STEP_M = 100.0 * FT  # profile table resolution
# Rows of the table: 0, 100, ..., 45,000 ft (built as BlueSky builds it, to the same bits).
ALT_AXIS_M = np.arange(0.0, 45000.0 * FT + ALT_STEP_M, ALT_STEP_M)
N_ALT = ALT_AXIS_M.shape[0]
ALT_MAX_M = float(ALT_AXIS_M[-1])  # top of the profile table
APPLY_ABOVE_M = 50.0 * FT  # wind moves aircraft above this altitude only (BlueSky: "airborne")
_EPS_D2 = 1e-20  # deg^2, so that a point exactly on a definition point gets its wind


def wind_vector(direction_deg: float | np.ndarray, speed_mps: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(north, east) components [m/s] of a wind blowing FROM ``direction_deg`` at ``speed_mps``."""
    rad = np.radians(direction_deg) + math.pi
    return np.asarray(speed_mps * np.cos(rad)), np.asarray(speed_mps * np.sin(rad))


def wind_from(vnorth: float, veast: float) -> tuple[float, float]:
    """(direction the wind blows from [deg, 0..360), speed [m/s]) of a wind vector."""
    return (math.degrees(math.atan2(veast, vnorth)) + 180.0) % 360.0, math.hypot(vnorth, veast)


class WindField:
    """Wind definition points of one simulation (SI units: m, m/s, degrees)."""

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """No wind (``DEL WIND``)."""
        self.dim = 0
        self.lat = np.empty(0)
        self.lon = np.empty(0)
        self.vnorth = np.empty((N_ALT, 0))  # [altitude row, point]
        self.veast = np.empty((N_ALT, 0))
        self._arrays: tuple[np.ndarray, ...] | None = None

    def __len__(self) -> int:
        return self.lat.shape[0]

    @property
    def active(self) -> bool:
        return self.dim > 0

    def add_point(self, lat: float, lon: float, direction_deg: float, speed_mps: float) -> int:
        """Wind at a point, the same at every altitude; returns the point's index."""
        vn, ve = wind_vector(direction_deg, speed_mps)
        return self._append(lat, lon, np.full(N_ALT, float(vn)), np.full(N_ALT, float(ve)), profile=False)

    def add_profile(self, lat: float, lon: float, alt_m: np.ndarray, direction_deg: np.ndarray,
                    speed_mps: np.ndarray) -> int:
        """Wind at a point given at several altitudes (linear between them, constant beyond)."""
        alt_m, direction_deg, speed_mps = (np.asarray(a, dtype=float) for a in (alt_m, direction_deg, speed_mps))
        if not alt_m.shape == direction_deg.shape == speed_mps.shape or alt_m.size == 0:
            raise ValueError("a wind profile needs the same number of altitudes, directions and speeds")
        # The table interpolates over increasing altitude; BlueSky leaves the order to the user.
        order = np.argsort(alt_m, kind="stable")
        vn, ve = wind_vector(direction_deg[order], speed_mps[order])
        alts = alt_m[order]
        return self._append(lat, lon, np.interp(ALT_AXIS_M, alts, vn), np.interp(ALT_AXIS_M, alts, ve), profile=True)

    def _append(self, lat: float, lon: float, vn: np.ndarray, ve: np.ndarray, profile: bool) -> int:
        self.lat = np.append(self.lat, float(lat))
        self.lon = np.append(self.lon, float(lon))
        self.vnorth = np.ascontiguousarray(np.column_stack((self.vnorth, vn)))
        self.veast = np.ascontiguousarray(np.column_stack((self.veast, ve)))
        if profile:
            self.dim = 3
        elif self.dim < 3:
            self.dim = min(2, len(self))
        self._arrays = None
        return len(self) - 1

    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(lat, lon, vnorth, veast, dim)`` for :func:`wind_at` (``dim`` as a one-element int array)."""
        if self._arrays is None:
            self._arrays = (self.lat, self.lon, self.vnorth, self.veast, np.array([self.dim], dtype=np.int64))
        return self._arrays

    def get(self, lat: float, lon: float, alt_m: float = 0.0) -> tuple[float, float]:
        """(north, east) wind [m/s] at a position and altitude."""
        return wind_at(self.arrays(), float(lat), float(lon), float(alt_m))



@njit(cache=True, inline="always")
def wind_at(w: tuple[np.ndarray, ...], lat: float, lon: float, alt: float) -> tuple[float, float]:
    """(north, east) wind [m/s] of the field ``w`` (:meth:`WindField.arrays`) at a position."""
    wlat, wlon, wvn, wve, wdim = w
    dim = wdim[0]
    if dim == 0:
        return 0.0, 0.0
    if dim == 1:
        return wvn[0, 0], wve[0, 0]
    if dim == 2:
        row0, row1, frac = 0, 0, 0.0
    else:
        pos = max(0.0, min(ALT_MAX_M, alt) / ALT_STEP_M)
        row0 = min(int(math.floor(pos)), N_ALT - 1)
        frac = pos - row0
        # At the top of the table BlueSky reads one row past its end; the top row holds.
        row1 = min(row0 + 1, N_ALT - 1)
    # One pass: the weights' sum divides at the end (BlueSky normalises each weight
    # first; the two differ in the last bit).
    total = vn0 = ve0 = vn1 = ve1 = 0.0
    for k in range(wlat.shape[0]):
        dy = lat - wlat[k]
        dx = math.cos(math.radians(0.5 * (lat + wlat[k]))) * (lon - wlon[k])
        weight = 1.0 / (_EPS_D2 + dx * dx + dy * dy)
        total += weight
        vn0 += wvn[row0, k] * weight
        ve0 += wve[row0, k] * weight
        if dim == 3:
            vn1 += wvn[row1, k] * weight
            ve1 += wve[row1, k] * weight
    if dim == 2:
        return vn0 / total, ve0 / total
    return ((1.0 - frac) * vn0 + frac * vn1) / total, ((1.0 - frac) * ve0 + frac * ve1) / total
