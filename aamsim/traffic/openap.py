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
   (take-off flaps in the initial climb, landing flaps on approach, clean
   otherwise) at level-flight lift, and the **maximum thrust** of its engines
   (OpenAP's three-segment in-flight model of altitude, CAS, Mach and climb
   rate);
4. limits the **acceleration** to (maximum thrust - drag) / mass, at least
   0.5 m/s^2, and 2 m/s^2 on the ground.

The step kernel then uses these limits until the next refresh; on the ground
an aircraft slower than its take-off speed does not climb.

The formulas are OpenAP's and BlueSky's published model (see
``docs/performance.md``); the coefficients come from
``traffic/data/openap_fixwing.json``; the rows read and written are named in
:mod:`aamsim.traffic.fields`. The refresh is compiled: it runs every second of
sim time while fixed-wing aircraft fly (a NumPy version over 600 aircraft cost
0.2 ms a refresh, 12 % of a whole run).
"""

from __future__ import annotations

import math

import numpy as np

from aamsim import aero
from aamsim.numba_cache import njit
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





@njit(cache=True, error_model="numpy")
def flight_phase(vs: float, alt: float) -> int:
    """BlueSky's OpenAP phase of a fixed-wing aircraft from vertical speed [m/s] and altitude [m].

    Later rules win where two apply, as in BlueSky (at exactly 75 ft a
    climbing aircraft is in its initial climb, at exactly 1,000 ft in its climb).
    """
    roc = vs / FPM
    alt_ft = alt / FT
    climbing, descending = roc >= 150.0, roc <= -150.0
    phase = PHASE_NA
    if alt_ft <= 75.0:
        phase = PHASE_GD
    if 75.0 <= alt_ft <= 1000.0:
        if climbing:
            phase = PHASE_IC
        elif descending:
            phase = PHASE_AP
    if alt_ft >= 1000.0:
        if climbing:
            phase = PHASE_CL
        elif descending:
            phase = PHASE_DE
    if alt_ft >= 10000.0 and not climbing and not descending:
        phase = PHASE_CR
    return phase


@njit(cache=True, error_model="numpy")
def inflight_max_thrust(max_thrust: float, tas: float, alt: float, vs: float) -> float:
    """Maximum thrust [N] in flight: OpenAP's model below FL100, FL100-FL350 and above FL350.

    ``max_thrust`` is the static maximum thrust of all engines [N]; the model
    scales a top-of-climb thrust estimated from it by pressure, CAS and climb rate.
    """
    # The reference point: pressure at FL350 (and FL100), the CAS of Mach 0.8 at FL350.
    p35 = aero.pressure(_H35)
    vcas_ref = aero.tas2cas_scalar(_MACH_REF * aero.speed_of_sound(_H35), _H35)
    roc = abs(vs / FPM)
    tas = max(tas, 10.0)
    mach = tas / aero.speed_of_sound(alt)
    vcas = aero.tas2cas_scalar(tas, alt)
    p = aero.pressure(alt)
    f35 = (200.0 + 0.2 * max_thrust / LBF) * LBF  # top-of-climb thrust [N]
    mratio, vratio = mach / _MACH_REF, vcas / vcas_ref
    if alt > _H35:
        ratio = (-0.4204 * mratio + 1.0824) * math.log(p / p35) + mratio**-0.11
    else:
        a = vratio**-0.1
        n = 2.667e-05 * roc + 0.8633
        if alt > _H10:
            ratio = a * (p / p35) ** (-0.355 * vratio + n)
        else:
            # Linear in pressure, continuous with the segment above at FL100.
            p10 = aero.pressure(_H10)
            ratio_f10 = a * (p10 / p35) ** (-0.355 * vratio + n)
            m = -1.2043e-1 * vratio - 8.8889e-9 * roc**2 + 2.4444e-5 * roc + 4.7379e-1
            ratio = m * (p / p35) + (ratio_f10 - m * (p10 / p35))
    return ratio * f35


@njit(cache=True, error_model="numpy")
def refresh(F: np.ndarray, n: int) -> bool:
    """Phase, speed range, acceleration limit and take-off gate of every fixed-wing aircraft.

    Writes the rows ``phase``, ``vmin``, ``vmax``, ``axmax`` and ``takeoff_tas``
    of the slots below ``n`` that carry OpenAP coefficients; returns whether
    there were any (then the limits change with the state and must be
    refreshed at every performance interval).
    """
    found = False
    for i in range(n):
        mass = F[f.FW_MASS, i]
        if not math.isfinite(mass):
            continue
        found = True
        tas, vs, alt = F[f.TAS, i], F[f.VS, i], F[f.ALT, i]
        phase = flight_phase(vs, alt)
        ground = phase == PHASE_GD
        if ground:
            # BlueSky computes drag and a take-off thrust here, then sets this limit whatever they are.
            vmin, vmax, axmax = 0.0, F[f.FW_VMAXIC, i], GROUND_AXMAX
        else:
            # Speed range (CAS) and drag polar of the phase's configuration.
            if phase == PHASE_AP:
                vmin, vmax = F[f.FW_VMINAP, i], F[f.FW_VMAXAP, i]
                cd0, k = F[f.FW_CD0_LANDING, i], F[f.FW_K_LANDING, i]
            else:
                vmin, vmax = F[f.FW_VMINER, i], F[f.FW_VMAXER, i]
                if phase == PHASE_IC:
                    cd0, k = F[f.FW_CD0_TAKEOFF, i], F[f.FW_K_TAKEOFF, i]
                else:
                    cd0, k = F[f.FW_CD0_CLEAN, i], F[f.FW_K_CLEAN, i]
            # Drag at level-flight lift; without airspeed it is undefined (0 x inf): BlueSky's
            # limit becomes NaN, so the speed takes its commanded value at once. aamsim says
            # so with an infinite limit.
            qs = 0.5 * aero.density(alt) * tas * tas * F[f.FW_WING_AREA, i]
            if qs > 0.0:
                cl = mass * G0 / qs
                drag = qs * (cd0 + k * cl * cl)
                axmax = max((inflight_max_thrust(F[f.FW_MAX_THRUST, i], tas, alt, vs) - drag) / mass, MIN_AXMAX)
            else:
                axmax = math.inf
        F[f.PHASE, i] = phase
        F[f.VMIN, i] = vmin
        F[f.VMAX, i] = vmax
        F[f.AXMAX, i] = axmax
        F[f.TAKEOFF_TAS, i] = F[f.FW_VMINTO, i] if ground else math.nan
    return found
