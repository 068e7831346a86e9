"""International Standard Atmosphere and airspeed conversions (SI units).

The formulas are the standard ISA troposphere/lower-stratosphere model and the
compressible-flow CAS <-> TAS relations, with the same constants BlueSky uses,
so that speeds agree with it to floating-point precision. Each function works
on floats inside the Numba step kernel and on numpy arrays elsewhere.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Protocol, cast, overload

import numpy as np
from numba import vectorize

from aamsim.numba_cache import njit, prepare

P0 = 101325.0  # Pa, sea-level pressure
RHO0 = 1.225  # kg/m^3, sea-level density
T0 = 288.15  # K, sea-level temperature
T_STRAT = 216.65  # K, isothermal layer temperature (to 22 km)
R_AIR = 287.05287  # J/(kg K)
GAMMA = 1.40
LAPSE = -0.0065  # K/m below the tropopause


@njit(cache=True, inline="always")
def temperature(h: float) -> float:
    """ISA temperature [K] at geopotential altitude h [m]."""
    return max(T0 + LAPSE * h, T_STRAT)


@njit(cache=True, inline="always")
def density(h: float) -> float:
    """ISA density [kg/m^3] at altitude h [m]."""
    t = temperature(h)
    rho_trop = RHO0 * (t / T0) ** 4.256848030018761
    return rho_trop * math.exp(-max(0.0, h - 11000.0) / 6341.552161)


@njit(cache=True, inline="always")
def pressure(h: float) -> float:
    """ISA pressure [Pa] at altitude h [m]."""
    return density(h) * R_AIR * temperature(h)


@njit(cache=True, inline="always")
def speed_of_sound(h: float) -> float:
    """Speed of sound [m/s] at altitude h [m]."""
    return math.sqrt(GAMMA * R_AIR * temperature(h))


@njit(cache=True)
def cas2tas_scalar(cas: float, h: float) -> float:
    """Calibrated to true airspeed [m/s] at altitude h [m] (sign preserved)."""
    rho = density(h)
    p = rho * R_AIR * temperature(h)
    qdyn = P0 * ((1.0 + RHO0 * cas * cas / (7.0 * P0)) ** 3.5 - 1.0)
    tas = math.sqrt(7.0 * p / rho * ((1.0 + qdyn / p) ** (2.0 / 7.0) - 1.0))
    return -tas if cas < 0.0 else tas


@njit(cache=True)
def tas2cas_scalar(tas: float, h: float) -> float:
    """True to calibrated airspeed [m/s] at altitude h [m] (sign preserved)."""
    rho = density(h)
    p = rho * R_AIR * temperature(h)
    qdyn = p * ((1.0 + rho * tas * tas / (7.0 * p)) ** 3.5 - 1.0)
    cas = math.sqrt(7.0 * P0 / RHO0 * ((qdyn / P0 + 1.0) ** (2.0 / 7.0) - 1.0))
    return -cas if tas < 0.0 else cas


@njit(cache=True, inline="always")
def mach2tas_scalar(mach: float, h: float) -> float:
    """Mach number to true airspeed [m/s] at altitude h [m]."""
    return mach * speed_of_sound(h)


@njit(cache=True)
def spd2tas_scalar(spd: float, is_mach: bool, h: float) -> float:
    """A commanded speed (CAS m/s, or Mach when ``is_mach``) to TAS [m/s]."""
    if is_mach:
        return mach2tas_scalar(spd, h)
    return cas2tas_scalar(spd, h)


def _cas2tas_element(cas: float, h: float) -> float:
    return cas2tas_scalar(cas, h)


def _tas2cas_element(tas: float, h: float) -> float:
    return tas2cas_scalar(tas, h)


class SpeedConversion(Protocol):
    """A speed conversion at an altitude: a float for two floats, else an array (numpy broadcasting)."""

    @overload
    def __call__(self, speed: float, h: float) -> float: ...
    @overload
    def __call__(self, speed: np.ndarray | list[float], h: np.ndarray | list[float] | float) -> np.ndarray: ...
    @overload
    def __call__(self, speed: float, h: np.ndarray | list[float]) -> np.ndarray: ...


def _conversion(name: str, scalar: Callable[[float, float], float], element: Callable[[float, float], float],
                doc: str) -> SpeedConversion:
    """Floats go to the compiled ``scalar``; arrays to a Numba ufunc of ``element`` built at its first use
    (building one costs a tenth of a second, its wrapper is not cached, and a plain run converts single
    speeds only). Both run the same machine code: the results agree bit for bit."""
    ufunc: list[Callable[..., Any]] = []

    def convert(speed: Any, h: Any) -> Any:
        if np.ndim(speed) == 0 and np.ndim(h) == 0:
            return scalar(float(speed), float(h))
        if not ufunc:
            prepare()  # the cache directory keyed by the sources, before Numba picks one for the ufunc
            ufunc.append(vectorize(["float64(float64, float64)"], cache=True)(element))
        return ufunc[0](speed, h)

    convert.__name__ = convert.__qualname__ = name
    convert.__doc__ = doc
    return cast(SpeedConversion, convert)


cas2tas = _conversion("cas2tas", cas2tas_scalar, _cas2tas_element,
                      "Vectorised :func:`cas2tas_scalar` (numpy arrays or floats; a float for two floats).")
tas2cas = _conversion("tas2cas", tas2cas_scalar, _tas2cas_element,
                      "Vectorised :func:`tas2cas_scalar` (numpy arrays or floats; a float for two floats).")


def mach2tas(mach: np.ndarray | float, h: np.ndarray | float) -> np.ndarray | float:
    """Mach number to TAS [m/s]."""
    t = np.maximum(T0 + LAPSE * np.asarray(h, dtype=float), T_STRAT)
    return mach * np.sqrt(GAMMA * R_AIR * t)


def tas2mach(tas: np.ndarray | float, h: np.ndarray | float) -> np.ndarray | float:
    """TAS [m/s] to Mach number."""
    t = np.maximum(T0 + LAPSE * np.asarray(h, dtype=float), T_STRAT)
    return tas / np.sqrt(GAMMA * R_AIR * t)


def mach2cas(mach: float, h: float) -> float:
    """Mach number to CAS [m/s] at altitude h [m]."""
    return float(tas2cas(mach2tas(mach, h), h))
