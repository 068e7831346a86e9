"""BlueSky's ``bluesky.tools.aero``: units, the ISA atmosphere and airspeed conversions (SI units).

The constants and formulas are BlueSky 1.1.1's (the same ISA and compressible-flow
relations :mod:`aamsim.aero` uses), evaluated in the same order so that results
agree bit for bit. The ``v...`` functions take numpy arrays; the others take
floats, and their atmosphere (:func:`atmos`) follows the ISA layers up to
86 km, as BlueSky's scalar functions do, where the vectorised ones use the
troposphere and the isothermal layer only.

A speed given as "CAS or Mach" (:func:`vcasormach`, :func:`casormach`) is a Mach
number when it lies strictly between 0.1 and :data:`casmach_thr` (2.0), as in
BlueSky's Python API.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from aamsim.compat.bluesky import settings
from aamsim.compat.bluesky._errors import not_provided

kts = 0.514444  # m/s per knot
ft = 0.3048  # m per foot
fpm = ft / 60.0  # m/s per foot per minute
inch = 0.0254  # m per inch
sqft = 0.09290304  # m^2 per square foot
nm = 1852.0  # m per nautical mile
lbs = 0.453592  # kg per pound
g0 = 9.80665  # m/s^2
R = 287.05287  # J/(kg K)
p0 = 101325.0  # Pa, sea level (ISA)
rho0 = 1.225  # kg/m^3, sea level (ISA)
T0 = 288.15  # K, sea level (ISA)
Tstrat = 216.65  # K, isothermal layer to 22 km
gamma = 1.40
gamma1 = 0.2  # (gamma - 1) / 2
gamma2 = 3.5  # gamma / (gamma - 1)
beta = -0.0065  # K/m, lapse rate below the tropopause
Rearth = 6371000.0  # m, mean earth radius
a0 = np.sqrt(gamma * R * T0)  # m/s, speed of sound at sea level
casmach_thr = settings.casmach_threshold  # m/s

Num = Any  # float or numpy array

# ------------------------------------------------------------------ vectorised (troposphere + isothermal layer)


def vtemp(h: Num) -> Num:
    """ISA temperature [K] at altitude h [m]."""
    return np.maximum(288.15 - 0.0065 * h, Tstrat)


def vatmos(h: Num) -> tuple[Num, Num, Num]:
    """ISA pressure [Pa], density [kg/m^3] and temperature [K] at altitude h [m]."""
    t = vtemp(h)
    rho = 1.225 * (t / 288.15) ** 4.256848030018761 * np.exp(-np.maximum(0.0, h - 11000.0) / 6341.552161)
    return rho * R * t, rho, t


def vpressure(h: Num) -> Num:
    """ISA pressure [Pa] at altitude h [m]."""
    return vatmos(h)[0]


def vdensity(h: Num) -> Num:
    """ISA density [kg/m^3] at altitude h [m]."""
    return vatmos(h)[1]


def vvsound(h: Num) -> Num:
    """Speed of sound [m/s] at altitude h [m]."""
    return np.sqrt(gamma * R * vtemp(h))


def vtas2mach(tas: Num, h: Num) -> Num:
    """TAS [m/s] to Mach number."""
    return tas / vvsound(h)


def vmach2tas(mach: Num, h: Num) -> Num:
    """Mach number to TAS [m/s]."""
    return mach * vvsound(h)


def veas2tas(eas: Num, h: Num) -> Num:
    """Equivalent to true airspeed [m/s]."""
    return eas * np.sqrt(rho0 / vdensity(h))


def vtas2eas(tas: Num, h: Num) -> Num:
    """True to equivalent airspeed [m/s]."""
    return tas * np.sqrt(vdensity(h) / rho0)


def vcas2tas(cas: Num, h: Num) -> Num:
    """Calibrated to true airspeed [m/s] (a negative CAS gives a negative TAS)."""
    p, rho, _ = vatmos(h)
    qdyn = p0 * ((1.0 + rho0 * cas * cas / (7.0 * p0)) ** 3.5 - 1.0)
    tas = np.sqrt(7.0 * p / rho * ((1.0 + qdyn / p) ** (2.0 / 7.0) - 1.0))
    return np.where(cas < 0, -1 * tas, tas)


def vtas2cas(tas: Num, h: Num) -> Num:
    """True to calibrated airspeed [m/s] (a negative TAS gives a negative CAS)."""
    p, rho, _ = vatmos(h)
    qdyn = p * ((1.0 + rho * tas * tas / (7.0 * p)) ** 3.5 - 1.0)
    cas = np.sqrt(7.0 * p0 / rho0 * ((qdyn / p0 + 1.0) ** (2.0 / 7.0) - 1.0))
    return np.where(tas < 0, -1 * cas, cas)


def vmach2cas(mach: Num, h: Num) -> Num:
    """Mach number to CAS [m/s]."""
    return vtas2cas(vmach2tas(mach, h), h)


def vcas2mach(cas: Num, h: Num) -> Num:
    """CAS [m/s] to Mach number."""
    return vtas2mach(vcas2tas(cas, h), h)


def _is_mach(spd: Num) -> Num:
    return np.logical_and(spd > 0.1, spd < casmach_thr)


def vcasormach(spd: Num, h: Num) -> tuple[Num, Num, Num]:
    """TAS [m/s], CAS [m/s] and Mach of a speed that is a Mach number below :data:`casmach_thr`, else a CAS."""
    ismach = _is_mach(spd)
    tas = np.where(ismach, vmach2tas(spd, h), vcas2tas(spd, h))
    cas = np.where(ismach, vtas2cas(tas, h), spd)
    mach = np.where(ismach, spd, vtas2mach(tas, h))
    return tas, cas, mach


def vcasormach2tas(spd: Num, h: Num) -> Num:
    """TAS [m/s] of a speed that is a Mach number below :data:`casmach_thr`, else a CAS."""
    return np.where(_is_mach(spd), vmach2tas(spd, h), vcas2tas(spd, h))


def crossoveralt(cas: Num, mach: Num) -> Num:
    """Altitude [m] where a CAS [m/s] and a Mach number give the same TAS (BADA 3.12, p. 12)."""
    delta = (((1.0 + 0.5 * (gamma - 1.0) * (cas / a0) ** 2) ** (gamma / (gamma - 1.0)) - 1.0)
             / ((1.0 + 0.5 * (gamma - 1.0) * mach ** 2) ** (gamma / (gamma - 1.0)) - 1.0))
    theta = delta ** (-beta * R / g0)
    return 1000.0 / 6.5 * T0 * (1.0 - theta)


# ------------------------------------------------------------------ scalar (ISA layers to 86 km)

_LAYER_BASE_M = (0.0, 11000.0, 20000.0, 32000.0, 47000.0, 51000.0, 71000.0, 86852.0)
_LAYER_P_PA = (101325.0, 22631.7009099, 5474.71768857, 867.974468302, 110.898214043, 66.939, 3.9564)
_LAYER_T_K = (288.15, 216.65, 216.65, 228.65, 270.65, 270.65, 214.65)
_LAYER_LAPSE = (-0.0065, 0, 0.001, 0.0028, 0, -0.0028, -0.002)  # K/m; 0: isothermal


def _layer(h: float) -> tuple[float, int]:
    """The altitude clipped to 0..86852 m and its ISA layer."""
    h = max(0.0, min(float(h), _LAYER_BASE_M[-1]))
    i = 0
    while h > _LAYER_BASE_M[i + 1] and i < len(_LAYER_BASE_M) - 2:
        i += 1
    return h, i


def atmos(h: float) -> tuple[float, float, float]:
    """ISA pressure [Pa], density [kg/m^3] and temperature [K] at altitude h [m], clipped to 0..86852 m."""
    h, i = _layer(h)
    base_t, lapse = _LAYER_T_K[i], _LAYER_LAPSE[i]
    if lapse == 0:
        t = base_t
        p = _LAYER_P_PA[i] * math.exp(-g0 / (R * t) * (h - _LAYER_BASE_M[i]))
    else:
        t = base_t + lapse * (h - _LAYER_BASE_M[i])
        p = _LAYER_P_PA[i] * ((t / base_t) ** (-g0 / (lapse * R)))
    return p, p / (R * t), t


def temp(h: float) -> float:
    """ISA temperature [K] at altitude h [m] (layers to 86 km)."""
    h, i = _layer(h)
    lapse = _LAYER_LAPSE[i]
    return _LAYER_T_K[i] if lapse == 0 else _LAYER_T_K[i] + lapse * (h - _LAYER_BASE_M[i])


def pressure(h: float) -> float:
    """ISA pressure [Pa] at altitude h [m]."""
    return atmos(h)[0]


def density(h: float) -> float:
    """ISA density [kg/m^3] at altitude h [m]."""
    return atmos(h)[1]


def vsound(h: float) -> float:
    """Speed of sound [m/s] at altitude h [m]."""
    return math.sqrt(gamma * R * temp(h))


def tas2mach(tas: float, h: float) -> float:
    """TAS [m/s] to Mach number."""
    return tas / vsound(h)


def mach2tas(M: float, h: float) -> float:
    """Mach number to TAS [m/s]."""
    return M * vsound(h)


def eas2tas(eas: float, h: float) -> float:
    """Equivalent to true airspeed [m/s]."""
    return eas * math.sqrt(rho0 / density(h))


def tas2eas(tas: float, h: float) -> float:
    """True to equivalent airspeed [m/s]."""
    return tas * math.sqrt(density(h) / rho0)


def cas2tas(cas: float, h: float) -> float:
    """Calibrated to true airspeed [m/s] (sign kept)."""
    p, rho, _ = atmos(h)
    qdyn = p0 * ((1.0 + rho0 * cas * cas / (7.0 * p0)) ** 3.5 - 1.0)
    tas = math.sqrt(7.0 * p / rho * ((1.0 + qdyn / p) ** (2.0 / 7.0) - 1.0))
    return -1 * tas if cas < 0 else tas


def tas2cas(tas: float, h: float) -> float:
    """True to calibrated airspeed [m/s] (sign kept)."""
    p, rho, _ = atmos(h)
    qdyn = p * ((1.0 + rho * tas * tas / (7.0 * p)) ** 3.5 - 1.0)
    cas = math.sqrt(7.0 * p0 / rho0 * ((qdyn / p0 + 1.0) ** (2.0 / 7.0) - 1.0))
    return -1 * cas if tas < 0 else cas


def mach2cas(M: float, h: float) -> float:
    """Mach number to CAS [m/s]."""
    return tas2cas(mach2tas(M, h), h)


def cas2mach(cas: float, h: float) -> float:
    """CAS [m/s] to Mach number."""
    return tas2mach(cas2tas(cas, h), h)


def casormach(spd: float, h: float) -> tuple[float, float, float]:
    """TAS, CAS [m/s] and Mach of a speed that is a Mach number below :data:`casmach_thr`, else a CAS."""
    if 0.1 < spd < casmach_thr:
        return mach2tas(spd, h), mach2cas(spd, h), spd
    return cas2tas(spd, h), spd, cas2mach(spd, h)


def casormach2tas(spd: float, h: float) -> float:
    """TAS [m/s] of a speed that is a Mach number below :data:`casmach_thr`, else a CAS."""
    return mach2tas(spd, h) if 0.1 < spd < casmach_thr else cas2tas(spd, h)


def metres_to_feet_rounded(metres: float) -> int:
    """Metres to whole feet."""
    return round(metres / ft)


def metric_spd_to_knots_rounded(speed: float) -> int:
    """m/s to whole knots."""
    return round(speed / kts)


def __getattr__(name: str) -> Any:
    if name.startswith("__"):
        raise AttributeError(name)
    hint = "CASMACHTHR is not a command of aamsim (docs/bluesky-differences.md, 4.5)" if name == "casmachthr" else ""
    raise not_provided(f"bluesky.tools.aero.{name}", hint)
