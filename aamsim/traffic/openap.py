"""Fixed-wing performance as BlueSky's OpenAP model computes it, at each performance refresh.

BlueSky 1.1.1 flies fixed-wing aircraft with its OpenAP model. Once a second
(the performance timer) it

1. infers each aircraft's **flight phase** from altitude and vertical speed
   (ground below 75 ft; initial climb or approach up to 1,000 ft; climb or
   descent above; cruise level above 10,000 ft; otherwise unknown);
2. sets the **speed range** (CAS) of that phase: on the ground 0 to the
   initial-climb maximum, on approach the approach range, otherwise the
   en-route range;
3. computes **drag** from the drag polar of the phase's configuration
   (take-off flaps and gear on the ground, take-off flaps in the initial
   climb, landing flaps on approach, clean otherwise) at level-flight lift,
   and the **maximum thrust** of its engines (a take-off thrust ratio on the
   ground, OpenAP's three-segment in-flight model of altitude, CAS, Mach and
   climb rate otherwise);
4. limits the **acceleration** to (maximum thrust - drag) / mass, at least
   0.5 m/s^2, and 2 m/s^2 on the ground.

The step kernel then uses these limits until the next refresh; on the ground
an aircraft slower than its take-off speed does not climb.

The formulas are OpenAP's and BlueSky's published model (see
``docs/performance.md``); the coefficients come from
``traffic/data/openap_fixwing.json``. Everything here works on the arrays of
all fixed-wing aircraft at once; the rows it reads and writes are named in
:mod:`aamsim.traffic.fields`.
"""

from __future__ import annotations

import numpy as np

from aamsim import aero
from aamsim.traffic import fields as f
from aamsim.units import FPM, FT

# Flight phases, BlueSky's OpenAP codes.
PHASE_NA, PHASE_GD, PHASE_IC, PHASE_CL, PHASE_CR, PHASE_DE, PHASE_AP = range(7)
PHASE_NAMES = ("unknown", "ground", "initial climb", "climb", "cruise", "descent", "approach")

GROUND_AXMAX = 2.0  # m/s^2 on the ground
MIN_AXMAX = 0.5  # m/s^2, the least any aircraft gets in flight
G0 = 9.80665  # m/s^2
LBF = 4.448  # N per pound-force, as OpenAP's thrust model rounds it

# Reference point of the in-flight thrust model: top of climb at FL350, Mach 0.8.
_MACH_REF = 0.8
_H10 = 10_000.0 * FT
_H35 = 35_000.0 * FT


def _isa(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ISA density [kg/m^3] and pressure [Pa] at altitudes h [m] (as aamsim.aero, on arrays)."""
    t = np.maximum(aero.T0 + aero.LAPSE * h, aero.T_STRAT)
    rho = aero.RHO0 * (t / aero.T0) ** 4.256848030018761 * np.exp(-np.maximum(0.0, h - 11000.0) / 6341.552161)
    return rho, rho * aero.R_AIR * t


_P10 = float(_isa(np.array([_H10]))[1][0])
_P35 = float(_isa(np.array([_H35]))[1][0])
_VCAS_REF = aero.mach2cas(_MACH_REF, _H35)


def flight_phase(vs: np.ndarray, alt: np.ndarray) -> np.ndarray:
    """BlueSky's OpenAP phase of fixed-wing aircraft from vertical speed [m/s] and altitude [m].

    Later rules win where two apply, as in BlueSky (at exactly 75 ft a
    climbing aircraft is in its initial climb, at exactly 1,000 ft in its climb).
    """
    roc = vs / FPM
    alt_ft = alt / FT
    climbing, descending = roc >= 150.0, roc <= -150.0
    low = (alt_ft >= 75.0) & (alt_ft <= 1000.0)
    high = alt_ft >= 1000.0
    phase = np.full(alt.shape, PHASE_NA, dtype=np.int64)
    phase[alt_ft <= 75.0] = PHASE_GD
    phase[low & climbing] = PHASE_IC
    phase[low & descending] = PHASE_AP
    phase[high & climbing] = PHASE_CL
    phase[high & descending] = PHASE_DE
    phase[(alt_ft >= 10000.0) & ~climbing & ~descending] = PHASE_CR
    return phase


def takeoff_thrust_ratio(bypass_ratio: np.ndarray, tas: np.ndarray, alt: np.ndarray) -> np.ndarray:
    """Maximum thrust on the ground as a fraction of static thrust (OpenAP's take-off model)."""
    g0 = 0.0606 * bypass_ratio + 0.6337
    mach = np.asarray(aero.tas2mach(tas, alt))
    pp = _isa(alt)[1] / aero.P0
    a = -0.4327 * pp**2 + 1.3855 * pp + 0.0472
    z = 0.9106 * pp**3 - 1.7736 * pp**2 + 1.8697 * pp
    x = 0.1377 * pp**3 - 0.4374 * pp**2 + 1.3003 * pp
    return (a - 0.377 * (1.0 + bypass_ratio) / np.sqrt((1.0 + 0.82 * bypass_ratio) * g0) * z * mach
            + (0.23 + 0.19 * np.sqrt(bypass_ratio)) * x * mach**2)


def inflight_max_thrust(max_thrust: np.ndarray, tas: np.ndarray, alt: np.ndarray, vs: np.ndarray) -> np.ndarray:
    """Maximum thrust [N] in flight: OpenAP's model below FL100, FL100-FL350 and above FL350.

    ``max_thrust`` is the static maximum thrust of all engines [N]; the model
    scales a top-of-climb thrust estimated from it by pressure, CAS and climb rate.
    """
    roc = np.abs(vs / FPM)
    tas = np.maximum(tas, 10.0)
    mach = np.asarray(aero.tas2mach(tas, alt))
    vcas = np.asarray(aero.tas2cas(tas, alt))
    p = _isa(alt)[1]
    f35 = (200.0 + 0.2 * max_thrust / LBF) * LBF  # top-of-climb thrust [N]
    mratio, vratio = mach / _MACH_REF, vcas / _VCAS_REF
    # Above FL350.
    ratio_high = (-0.4204 * mratio + 1.0824) * np.log(p / _P35) + mratio**-0.11
    # FL100 to FL350.
    a = vratio**-0.1
    n = 2.667e-05 * roc + 0.8633
    ratio_mid = a * (p / _P35) ** (-0.355 * vratio + n)
    # Below FL100: linear in pressure, continuous with the segment above at FL100.
    ratio_f10 = a * (_P10 / _P35) ** (-0.355 * vratio + n)
    m = -1.2043e-1 * vratio - 8.8889e-9 * roc**2 + 2.4444e-5 * roc + 4.7379e-1
    ratio_low = m * (p / _P35) + (ratio_f10 - m * (_P10 / _P35))
    ratio = np.where(alt > _H35, ratio_high, np.where(alt > _H10, ratio_mid, ratio_low))
    return ratio * f35


def refresh(F: np.ndarray, n: int) -> bool:
    """Phase, speed range, acceleration limit and take-off gate of every fixed-wing aircraft.

    Writes the rows ``phase``, ``vmin``, ``vmax``, ``axmax`` and ``takeoff_tas``
    of the slots below ``n`` that carry OpenAP coefficients; returns whether
    there were any (then the limits change with the state and must be
    refreshed at every performance interval).
    """
    slots = np.flatnonzero(np.isfinite(F[f.FW_MASS, :n]))
    if slots.size == 0:
        return False
    tas, vs, alt = F[f.TAS, slots], F[f.VS, slots], F[f.ALT, slots]
    phase = flight_phase(vs, alt)
    ground, initial, approach = phase == PHASE_GD, phase == PHASE_IC, phase == PHASE_AP

    # Speed range (CAS) of the phase.
    vmin = np.where(ground, 0.0, np.where(approach, F[f.FW_VMINAP, slots], F[f.FW_VMINER, slots]))
    vmax = np.where(ground, F[f.FW_VMAXIC, slots],
                    np.where(approach, F[f.FW_VMAXAP, slots], F[f.FW_VMAXER, slots]))

    # Drag at level-flight lift, in the phase's configuration.
    takeoff = ground | initial
    cd0 = np.where(takeoff, F[f.FW_CD0_TAKEOFF, slots],
                   np.where(approach, F[f.FW_CD0_LANDING, slots], F[f.FW_CD0_CLEAN, slots]))
    cd0 = cd0 + np.where(ground, F[f.FW_CD0_GEAR, slots], 0.0)
    k = np.where(takeoff, F[f.FW_K_TAKEOFF, slots],
                 np.where(approach, F[f.FW_K_LANDING, slots], F[f.FW_K_CLEAN, slots]))
    mass = F[f.FW_MASS, slots]
    with np.errstate(divide="ignore", invalid="ignore"):
        qs = 0.5 * _isa(alt)[0] * tas**2 * F[f.FW_WING_AREA, slots]
        cl = mass * G0 / qs
        drag = qs * (cd0 + k * cl**2)

        static = F[f.FW_MAX_THRUST, slots]
        max_thrust = np.where(ground, takeoff_thrust_ratio(F[f.FW_BYPASS_RATIO, slots], tas, alt) * static,
                              inflight_max_thrust(static, tas, alt, vs))
        axmax = (max_thrust - drag) / mass
    # Without airspeed in flight the drag is undefined (0 x inf): BlueSky's limit becomes NaN, so
    # the speed takes its commanded value at once. aamsim says so with an infinite limit.
    axmax = np.where(np.isnan(axmax), np.inf, np.maximum(axmax, MIN_AXMAX))
    axmax = np.where(ground, GROUND_AXMAX, axmax)

    F[f.PHASE, slots] = phase
    F[f.VMIN, slots] = vmin
    F[f.VMAX, slots] = vmax
    F[f.AXMAX, slots] = axmax
    F[f.TAKEOFF_TAS, slots] = np.where(ground, F[f.FW_VMINTO, slots], np.nan)
    return True
