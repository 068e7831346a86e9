"""The per-step traffic update, compiled with Numba.

One call advances every aircraft by up to ``nsteps`` time steps, in BlueSky's
order within a step:

1. LNAV: has the aircraft reached its active waypoint? If any has, the call
   returns *before* the step so that Python can start the next leg
   (:func:`aamsim.traffic.autopilot.pass_waypoint`) and then resume the same step;
2. autopilot: track to the waypoint, VNAV altitude/vertical speed, speed
   constraints, selected speed -> TAS;
3. performance limits on the commanded speed, vertical speed and altitude;
4. kinematics: speed ramps at ``axmax``, heading turns at g*tan(bank)/V,
   vertical speed ramps at 300 fpm/s, ground speed is the TAS vector plus the
   wind (:mod:`aamsim.traffic.wind`), then the flat-earth Euler position step;
5. conditional commands (ATALT/ATSPD/ATDIST): if one fires, the call returns
   after the step so that Python runs its command before the next one.

Aircraft are independent within a step, so each step is one plain scalar
pass over the slots, without allocation. Each aircraft is advanced, then its
waypoint test for the next step (1.) runs while its data is still in cache.

Measured choices that make the pass cheap:

* The per-aircraft code is compiled without NRT reference counting
  (``_nrt=False``). Counting the state arrays in and out of every call took
  a fifth of the time, as atomic operations.
* The state is Fortran-ordered (``Traffic``), so one aircraft's fields are
  contiguous.
* Atmosphere, CAS/TAS conversions, heading sines and the waypoint's
  trigonometry are cached per aircraft. Each cache is keyed by its input value.
* Guidance and the position update avoid libm as described in
  :mod:`aamsim.traffic.navmath`.

:func:`advance_parallel` splits the aircraft into blocks over Numba threads.
The blocks run the same compiled code, so the results are the same bit for
bit. :func:`advance_ranges` (and :func:`advance_ranges_parallel`) advance
given ranges of slots, each with its own waypoint test flag and settings: the
aircraft of several simulations whose state shares one matrix
(:mod:`aamsim.traffic.pool`) in one call.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
from numba import prange

from aamsim.aero import GAMMA, LAPSE, P0, R_AIR, RHO0, T0, T_STRAT
from aamsim.geo import qdrdist_scalar
from aamsim.numba_cache import njit
from aamsim.traffic.fields import (
    AIRBORNE_S,
    ALT,
    AP_ALT,
    AP_TAS,
    AP_TRK,
    AP_VS,
    ASAS_ALT,
    ASAS_GS,
    ASAS_TRK,
    ASAS_VS,
    AX,
    AXMAX,
    B_ASAS,
    B_C_SPD_MACH,
    B_HAS_MOVED,
    B_HAS_NEXTTURN,
    B_INTURN,
    B_NONCOOP,
    B_ROTOR,
    B_SELSPD_MACH,
    B_SWALTSEL,
    B_SWHDGSEL,
    B_SWLNAV,
    B_SWTOD,
    B_SWVNAV,
    B_SWVNAVSPD,
    B_SWVNAVVS,
    B_TURNTONEXTWP,
    B_WP_FLYBY,
    BANKDEF,
    C_A,
    C_ALT,
    C_APTAS_OUT,
    C_BANK,
    C_CAS_OUT,
    C_COSHDG,
    C_HDG,
    C_P,
    C_RHO,
    C_SINHDG,
    C_SPD_IN,
    C_TANBANK,
    C_TAS_IN,
    CAS,
    CRUISESPD,
    DIST2VS,
    DIST2WP,
    DISTFLOWN,
    GS,
    GSEAST,
    GSNORTH,
    HDG,
    HMAX,
    LAT,
    LON,
    MACH,
    MMO,
    QDR2WP,
    SELALT,
    SELSPD,
    SELVS,
    SLOW_S,
    TAKEOFF_TAS,
    TAS,
    TRK,
    TURNPHI,
    VMAX,
    VMIN,
    VNAVVS,
    VS,
    VSDEF,
    VSMAX,
    VSMIN,
    WP_CURLEGDIR,
    WP_NEXTALTCO,
    WP_NEXTSPD,
    WP_NEXTTURNLAT,
    WP_NEXTTURNLON,
    WP_NEXTTURNRAD,
    WP_NEXTTURNSPD,
    WP_OLDTURNSPD,
    WP_SPD,
    WP_SPDCON,
    WP_TURNDIST,
    WP_VS,
)
from aamsim.traffic.navmath import guidance, position_step, wrap180, wrap360
from aamsim.traffic.wind import APPLY_ABOVE_M, wind_at
from aamsim.units import FPM, G0, NM

STATUS_DONE = 0
STATUS_REACHED = 1  # returned before a step: reached[] marks aircraft at their waypoint
STATUS_CONDITION = 2  # returned after a step: fired[] marks conditions that triggered
STATUS_NONFINITE = 3  # returned after a step: some aircraft's state is no longer finite (Python removes it)
# Added to a block's count of reached waypoints when an aircraft of the block went non-finite.
_NONFINITE_MARK = 1 << 40

COND_ALT = 0
COND_SPD = 1
COND_DIST = 2

_FunctionT = TypeVar("_FunctionT", bound=Callable[..., Any])


def _njit_without_refcounts(fn: _FunctionT) -> _FunctionT:
    """``njit(cache=True)`` with Numba's (private) switch that leaves out NRT reference counting.

    See the module docstring; these functions allocate nothing. Like every function of the
    kernel, they use NumPy's error model: a division by zero gives inf or NaN, which the
    finiteness check after each step turns into an error naming the aircraft, instead of a
    ZeroDivisionError that would end the whole run (an altitude of +inf did that).
    """
    return njit(cache=True, _nrt=False, error_model="numpy")(fn)  # type: ignore[call-overload,no-any-return]


_VS_ACCEL = 300.0 * FPM  # m/s^2, vertical speed ramp
_EPS = 0.01


@njit(cache=True, inline="always", error_model="numpy")
def _atmosphere(F: np.ndarray, i: int, alt: float) -> tuple[float, float, float]:
    """(rho, p, speed of sound) at the aircraft's altitude, cached per aircraft."""
    if F[C_ALT, i] != alt:
        t = max(T0 + LAPSE * alt, T_STRAT)
        rho = RHO0 * (t / T0) ** 4.256848030018761 * math.exp(-max(0.0, alt - 11000.0) / 6341.552161)
        F[C_RHO, i] = rho
        F[C_P, i] = rho * R_AIR * t
        F[C_A, i] = math.sqrt(GAMMA * R_AIR * t)
        F[C_ALT, i] = alt
        # Speed conversions depend on altitude: drop their caches.
        F[C_TAS_IN, i] = math.nan
        F[C_SPD_IN, i] = math.nan
    return F[C_RHO, i], F[C_P, i], F[C_A, i]


@njit(cache=True, inline="always", error_model="numpy")
def _cas2tas(cas: float, rho: float, p: float) -> float:
    qdyn = P0 * ((1.0 + RHO0 * cas * cas / (7.0 * P0)) ** 3.5 - 1.0)
    tas = math.sqrt(7.0 * p / rho * ((1.0 + qdyn / p) ** (2.0 / 7.0) - 1.0))
    return -tas if cas < 0.0 else tas


@njit(cache=True, inline="always", error_model="numpy")
def _tas2cas(tas: float, rho: float, p: float) -> float:
    qdyn = p * ((1.0 + rho * tas * tas / (7.0 * p)) ** 3.5 - 1.0)
    cas = math.sqrt(7.0 * P0 / RHO0 * ((qdyn / P0 + 1.0) ** (2.0 / 7.0) - 1.0))
    return -cas if tas < 0.0 else cas


@njit(cache=True, error_model="numpy")
def _atmos_at(h: float) -> tuple[float, float, float]:
    t = max(T0 + LAPSE * h, T_STRAT)
    rho = RHO0 * (t / T0) ** 4.256848030018761 * math.exp(-max(0.0, h - 11000.0) / 6341.552161)
    return rho, rho * R_AIR * t, math.sqrt(GAMMA * R_AIR * t)


@njit(cache=True, inline="always", error_model="numpy")
def _reached(F: np.ndarray, B: np.ndarray, i: int, qdr: float, dist: float) -> bool:
    """BlueSky's waypoint-passing test for an aircraft flying LNAV."""
    gs = F[GS, i]
    close = dist < 4.0 * max(0.0001, abs(gs))  # less than 4 s away
    too_close_to_turn = close and abs(wrap180(wrap360(F[TRK, i]) - wrap360(qdr))) > 90.0
    away_or_passed = too_close_to_turn or abs(wrap180(qdr - F[WP_CURLEGDIR, i])) > 90.0
    turndist = F[WP_TURNDIST, i] if B[B_WP_FLYBY, i] else 0.0
    return away_or_passed or dist < turndist


@njit(cache=True, error_model="numpy")
def _wind_here(wind: tuple[np.ndarray, ...], lat: float, lon: float, alt: float) -> tuple[float, float]:
    """The wind field at a position (not inlined: keeps the step's code small)."""
    return wind_at(wind, lat, lon, alt)


@njit(cache=True, error_model="numpy")
def _wind_correction(des_trk: float, wind_n: float, wind_e: float, tas: float) -> float:
    """The heading [deg] that makes good the track ``des_trk`` at ``tas`` in the wind (BlueSky's APorASAS)."""
    wind_speed = math.sqrt(wind_n * wind_n + wind_e * wind_e)
    drift = math.radians(des_trk) - math.atan2(wind_e, wind_n)
    steer = math.asin(min(1.0, max(-1.0, wind_speed * math.sin(drift) / max(0.001, tas))))
    return des_trk + math.degrees(steer)


@njit(cache=True, error_model="numpy")
def _turn_speed(F: np.ndarray, B: np.ndarray, i: int, tas: float, rho: float, p: float, use_next: bool) -> None:
    """Speed selection of an aircraft with fly-turn waypoints (BlueSky's FMS speed guidance).

    With VNAV speed control on, the aircraft slows to the turn speed of the
    next fly-turn waypoint when it is within the distance needed to decelerate
    (plus 10 % and the turn radius) and keeps it through the turn, until its
    track is within 2 deg of the new leg. A cruise speed (CRUISESPD) is then
    selected if the new leg has no speed constraint. Otherwise the speed
    constraints select the speed as without turns.
    """
    nav = B[B_SWVNAVSPD, i] and B[B_SWVNAV, i] and B[B_SWLNAV, i]
    use_turn = False
    if B[B_HAS_NEXTTURN, i]:
        turntas = _cas2tas(F[WP_NEXTTURNSPD, i], rho, p)
        dx_turn = 0.5 * abs(tas * tas - turntas * turntas) / max(0.001, abs(F[AXMAX, i]))
        dist2turn = qdrdist_scalar(F[LAT, i], F[LON, i], F[WP_NEXTTURNLAT, i], F[WP_NEXTTURNLON, i])[1]
        near = dist2turn < dx_turn * 1.1 + max(F[WP_TURNDIST, i], F[WP_NEXTTURNRAD, i])
        use_turn = (B[B_TURNTONEXTWP, i] or near) and nav
    B[B_TURNTONEXTWP, i] = B[B_SWLNAV, i] and (B[B_TURNTONEXTWP, i] or use_turn)
    old = F[WP_OLDTURNSPD, i]
    on_leg = abs(wrap180(F[TRK, i] - F[QDR2WP, i])) < 2.0
    in_old_turn = old > 0.0 and not on_leg
    if on_leg and old > 0.0:
        F[WP_OLDTURNSPD, i] = math.nan
    if use_turn:
        F[SELSPD, i] = F[WP_NEXTTURNSPD, i]
        B[B_SELSPD_MACH, i] = False
    elif in_old_turn and nav:
        F[SELSPD, i] = old
        B[B_SELSPD_MACH, i] = False
    elif use_next:
        F[SELSPD, i] = F[WP_NEXTSPD, i]
        B[B_SELSPD_MACH, i] = False
    elif B[B_SWVNAVSPD, i] and F[WP_SPDCON, i] == F[WP_SPDCON, i]:
        F[SELSPD, i] = F[WP_SPD, i]
        B[B_SELSPD_MACH, i] = False
    was_in_turn = B[B_INTURN, i]
    B[B_INTURN, i] = use_turn or in_old_turn
    if was_in_turn and not B[B_INTURN, i] and F[CRUISESPD, i] > 0.0 and not use_next \
            and not F[WP_SPD, i] == F[WP_SPD, i]:
        F[SELSPD, i] = F[CRUISESPD, i]
        B[B_SELSPD_MACH, i] = False


@njit(cache=True, inline="always", error_model="numpy")
def _step_noncooperative(F: np.ndarray, i: int, dt: float, airborne_alt: float) -> None:
    """A replayed real aircraft: straight on at the velocity its replay set (no autopilot, no envelope).

    The replay (:mod:`aamsim.realtraffic.replay`) sets position and velocity at each of its
    updates so that this Euler step carries the aircraft along its interpolated track.
    """
    alt = F[ALT, i] + F[VS, i] * dt
    F[ALT, i] = alt
    position_step(F, i, dt, F[GSNORTH, i], F[GSEAST, i])
    F[DISTFLOWN, i] += F[GS, i] * dt
    if alt > airborne_alt:
        F[AIRBORNE_S, i] += dt


@njit(cache=True, inline="always", error_model="numpy")
def _step_aircraft(
    F: np.ndarray,
    B: np.ndarray,
    i: int,
    dt: float,
    qdr: float,
    dist: float,
    have_qdr: bool,
    hold_speed: float,
    airborne_alt: float,
    wind: tuple[np.ndarray, ...] | None,
    turns: tuple[()] | None,
    reso: tuple[()] | None,
) -> None:
    if B[B_NONCOOP, i]:
        _step_noncooperative(F, i, dt, airborne_alt)
        return
    alt = F[ALT, i]
    tas = F[TAS, i]
    swlnav = B[B_SWLNAV, i]
    swvnav = B[B_SWVNAV, i]
    rho, p, a = _atmosphere(F, i, alt)
    # Wind at the aircraft, where it is at the start of the step (BlueSky reads its field
    # there for the autopilot's wind correction and for the ground speed alike). ``wind``
    # and ``turns`` are None when there is no wind field / no fly-turn waypoint: Numba
    # then compiles a kernel without these parts. (Present but unused, the two branches
    # and their calls cost 8 % of the step: measured with bench/bench_sim.py.)
    windy = False
    wind_n = wind_e = 0.0
    if wind is not None:
        windy = True
        wind_n, wind_e = _wind_here(wind, F[LAT, i], F[LON, i], alt)

    # ---------------------------------------------------------------- autopilot
    if swlnav or swvnav:
        if not have_qdr:
            qdr, dist = guidance(F, i)
        F[QDR2WP, i] = wrap360(qdr)
        F[DIST2WP, i] = dist
    dist2wp = F[DIST2WP, i]
    turndist = F[WP_TURNDIST, i]
    nextaltco = F[WP_NEXTALTCO, i]
    swvnavvs = False
    if swvnav:
        if swlnav:
            if nextaltco == nextaltco:  # not NaN
                if alt > nextaltco:
                    swvnavvs = dist2wp < F[DIST2VS, i] + turndist or not B[B_SWTOD, i]
                elif alt < nextaltco:
                    swvnavvs = True
        else:
            swvnavvs = dist2wp <= max(0.1 * NM, turndist)
    B[B_SWVNAVVS, i] = swvnavvs
    if swvnavvs:
        F[VNAVVS, i] = F[WP_VS, i]
        ap_vs = F[WP_VS, i]
        ap_alt = nextaltco
        F[SELALT, i] = nextaltco
    else:
        selvs = F[SELVS, i]
        ap_vs = selvs if abs(selvs) > 0.1 else F[VSDEF, i]
        ap_alt = F[SELALT, i]
    if swlnav:
        F[AP_TRK, i] = F[QDR2WP, i]

    # Speed: an upcoming speed constraint is anticipated by the distance
    # needed to reach it; otherwise the constraint of the current leg holds.
    nextspd = F[WP_NEXTSPD, i]
    use_next = False
    if swlnav and swvnav and B[B_SWVNAVSPD, i] and nextspd == nextspd:
        nexttas = _cas2tas(nextspd, rho, p)
        dx_accel = 0.5 * abs(nexttas * nexttas - tas * tas) / max(0.001, abs(F[AXMAX, i]))
        use_next = dist2wp < dx_accel
    if turns is not None and (B[B_HAS_NEXTTURN, i] or F[WP_OLDTURNSPD, i] > 0.0 or B[B_INTURN, i]):
        _turn_speed(F, B, i, tas, rho, p, use_next)
    elif use_next:
        F[SELSPD, i] = nextspd
        B[B_SELSPD_MACH, i] = False
    elif B[B_SWVNAVSPD, i] and F[WP_SPDCON, i] == F[WP_SPDCON, i]:
        F[SELSPD, i] = F[WP_SPD, i]
        B[B_SELSPD_MACH, i] = False
    selspd = F[SELSPD, i]
    mach = B[B_SELSPD_MACH, i]
    if F[C_SPD_IN, i] == selspd and B[B_C_SPD_MACH, i] == mach:
        ap_tas = F[C_APTAS_OUT, i]
    else:
        ap_tas = selspd * a if mach else _cas2tas(selspd, rho, p)
        F[C_SPD_IN, i] = selspd
        B[B_C_SPD_MACH, i] = mach
        F[C_APTAS_OUT, i] = ap_tas
    F[AP_TAS, i] = ap_tas
    F[AP_ALT, i] = ap_alt
    F[AP_VS, i] = ap_vs

    des_trk = F[AP_TRK, i]
    if reso is not None and B[B_ASAS, i]:
        # Conflict resolution flies this aircraft (BlueSky's APorASAS): its track, its ground
        # speed less the wind here, its altitude and vertical speed replace the autopilot's
        # (which keeps its own outputs, resumed when the resolution ends).
        des_trk = F[ASAS_TRK, i]
        gs_cmd = F[ASAS_GS, i]
        if windy:
            trad = math.radians(des_trk)
            tas_n = gs_cmd * math.cos(trad) - wind_n
            tas_e = gs_cmd * math.sin(trad) - wind_e
            ap_tas = math.sqrt(tas_n * tas_n + tas_e * tas_e)
        else:
            ap_tas = gs_cmd
        ap_alt = F[ASAS_ALT, i]
        ap_vs = F[ASAS_VS, i]
    # The heading that makes good the desired track (BlueSky's APorASAS wind correction).
    if windy:
        des_trk = _wind_correction(des_trk, wind_n, wind_e, tas)

    # ------------------------------------------------------ performance limits
    des_hdg = wrap360(des_trk)
    des_vs = abs(ap_vs)
    des_alt = min(ap_alt, F[HMAX, i])
    axmax = F[AXMAX, i]
    if B[B_ROTOR, i]:
        des_tas = min(max(ap_tas, F[VMIN, i]), F[VMAX, i])
        des_vs = min(max(des_vs, F[VSMIN, i]), F[VSMAX, i])
    else:
        rho_h, p_h, a_h = _atmos_at(des_alt)
        cas_i = _tas2cas(ap_tas, rho_h, p_h)
        cas_l = min(max(cas_i, F[VMIN, i]), F[VMAX, i])
        des_tas = _cas2tas(cas_l, rho_h, p_h)
        if des_tas / a_h > F[MMO, i]:
            des_tas = F[MMO, i] * a_h
        # The command is a magnitude here (BlueSky's APorASAS takes its absolute value), so
        # BlueSky's descent-side limit never applies; only the climb rate limits it.
        if des_vs > F[VSMAX, i]:
            des_vs = (1.0 - F[AX, i] / axmax) * F[VSMAX, i]
        if tas < F[TAKEOFF_TAS, i]:  # on the ground below take-off speed (NaN: no gate)
            des_vs = 0.0

    # -------------------------------------------------------------- kinematics
    dspd = des_tas - tas
    if abs(dspd) > abs(dt * axmax):
        ax = axmax if dspd > 0.0 else -axmax
        tas = tas + ax * dt
    else:
        ax = 0.0
        tas = des_tas
    F[AX, i] = ax
    F[TAS, i] = tas
    if F[C_TAS_IN, i] != tas:
        # Also dropped when the altitude (so the speed of sound) changes.
        F[C_CAS_OUT, i] = _tas2cas(tas, rho, p)
        F[C_TAS_IN, i] = tas
        F[MACH, i] = tas / a
    F[CAS, i] = F[C_CAS_OUT, i]

    hdg = F[HDG, i]
    delhdg = wrap180(des_hdg - hdg)
    if delhdg != 0.0:
        phi = F[TURNPHI, i]
        bank = phi if phi > _EPS * _EPS else F[BANKDEF, i]
        if F[C_BANK, i] != bank:
            F[C_TANBANK, i] = math.tan(bank)
            F[C_BANK, i] = bank
        turnrate = math.degrees(G0 * F[C_TANBANK, i] / max(tas, _EPS))
        turning = abs(delhdg) > abs(dt * turnrate)
    else:
        turnrate = 0.0
        turning = False
    B[B_SWHDGSEL, i] = turning
    if turning:
        hdg = wrap360(hdg + dt * turnrate * (1.0 if delhdg > 0.0 else -1.0))
    else:
        hdg = des_hdg
    F[HDG, i] = hdg

    vs = F[VS, i]
    delalt = des_alt - alt
    altsel = abs(delalt) > 1.05 * max(abs(dt * des_vs), abs(dt * vs))
    B[B_SWALTSEL, i] = altsel
    if altsel:
        target_vs = des_vs if delalt > 0.0 else -des_vs
    else:
        target_vs = 0.0
    dvs = target_vs - vs
    if abs(dvs) > _VS_ACCEL:
        vs = vs + (_VS_ACCEL if dvs > 0.0 else -_VS_ACCEL) * dt
    else:
        vs = target_vs
    if not math.isfinite(vs):
        vs = 0.0
    F[VS, i] = vs

    if F[C_HDG, i] != hdg:
        hrad = math.radians(hdg)
        F[C_SINHDG, i] = math.sin(hrad)
        F[C_COSHDG, i] = math.cos(hrad)
        F[C_HDG, i] = hdg
    gsn = tas * F[C_COSHDG, i]
    gse = tas * F[C_SINHDG, i]
    if windy and alt > APPLY_ABOVE_M:
        # Ground speed = TAS vector + wind, for aircraft off the ground (BlueSky: above 50 ft).
        gsn += wind_n
        gse += wind_e
        gs = math.sqrt(gsn * gsn + gse * gse)
        F[TRK, i] = wrap360(math.degrees(math.atan2(gse, gsn)))
    else:
        gs = tas
        F[TRK, i] = hdg
    F[GSNORTH, i] = gsn
    F[GSEAST, i] = gse
    F[GS, i] = gs

    if altsel:
        alt = round(alt + vs * dt, 6)
    else:
        alt = des_alt
    F[ALT, i] = alt
    position_step(F, i, dt, gsn, gse)
    F[DISTFLOWN, i] += gs * dt
    # Airborne holding: slow while airborne, either after having flown or because the aircraft is
    # held there (its desired speed is under the threshold). The initial spin-up after a creation at
    # 0 kt, with a higher speed selected, is not holding; an aircraft told to hold from its creation
    # is (it once counted as 0 s: issue 28, a policy parking aircraft looked free).
    if abs(tas) >= hold_speed:
        B[B_HAS_MOVED, i] = True
    if alt > airborne_alt:
        F[AIRBORNE_S, i] += dt
        if abs(tas) < hold_speed and (B[B_HAS_MOVED, i] or des_tas < hold_speed):
            F[SLOW_S, i] += dt


@njit(cache=True, inline="always", error_model="numpy")
def _check_waypoint(
    F: np.ndarray, B: np.ndarray, i: int, scratch_qdr: np.ndarray, scratch_dist: np.ndarray,
    fresh: np.ndarray, reached: np.ndarray,
) -> int:
    """Guidance of aircraft ``i`` for the coming step and BlueSky's passing test (1: reached)."""
    reached[i] = False
    if B[B_SWLNAV, i]:
        q, d = guidance(F, i)
        scratch_qdr[i] = q
        scratch_dist[i] = d
        fresh[i] = True
        if _reached(F, B, i, q, d):
            reached[i] = True
            return 1
    else:
        fresh[i] = False
    return 0


@njit(cache=True, inline="always", error_model="numpy")
def _conditions_fired(F: np.ndarray, cond: tuple[np.ndarray, ...]) -> bool:
    """ATALT/ATSPD/ATDIST: flag the conditions whose target was crossed this step."""
    cond_ac, cond_type, cond_target, cond_lastdif, cond_lat, cond_lon, cond_fired = cond
    fired_any = False
    for c in range(cond_ac.shape[0]):
        i = cond_ac[c]
        kind = cond_type[c]
        if kind == COND_ALT:
            actual = F[ALT, i]
        elif kind == COND_SPD:
            actual = F[CAS, i]
        else:
            actual = qdrdist_scalar(F[LAT, i], F[LON, i], cond_lat[c], cond_lon[c])[1]
        dif = cond_target[c] - actual
        if dif * cond_lastdif[c] <= 0.0:
            cond_fired[c] = True
            fired_any = True
        cond_lastdif[c] = dif
    return fired_any


@_njit_without_refcounts
def _step_range(
    F: np.ndarray,
    B: np.ndarray,
    lo: int,
    hi: int,
    dt: float,
    test_next: bool,
    hold_speed: float,
    airborne_alt: float,
    scratch_qdr: np.ndarray,
    scratch_dist: np.ndarray,
    fresh: np.ndarray,
    reached: np.ndarray,
    wind: tuple[np.ndarray, ...] | None,
    turns: tuple[()] | None,
    reso: tuple[()] | None,
) -> int:
    """One step of aircraft ``lo..hi-1``; returns how many reached their waypoint.

    Each aircraft is advanced, then (unless ``test_next`` is False: the batch
    ends here) its guidance and waypoint test for the next step are computed
    while its data is still in cache. Aircraft are independent within a step,
    so this equals testing at the start of the next step.
    """
    nreached = 0
    # Position, altitude and TAS of every aircraft summed: a NaN or infinity in any state row reaches
    # one of them within the step (track, heading and ground speed feed the position, vertical speed
    # the altitude), so a sum that is not finite shows it. Summed here, while the aircraft is in
    # cache, as two independent pairs so the additions do not wait on each other (a chain over all
    # twelve state rows cost the kernel 10 %).
    state_sum = 0.0
    for i in range(lo, hi):
        _step_aircraft(F, B, i, dt, scratch_qdr[i], scratch_dist[i], fresh[i], hold_speed, airborne_alt, wind,
                       turns, reso)
        state_sum += (F[LAT, i] + F[LON, i]) + (F[ALT, i] + F[TAS, i])
        if test_next:
            nreached += _check_waypoint(F, B, i, scratch_qdr, scratch_dist, fresh, reached)
        else:
            fresh[i] = False
            reached[i] = False
    return nreached if math.isfinite(state_sum) else nreached + _NONFINITE_MARK


@_njit_without_refcounts
def _check_range(
    F: np.ndarray, B: np.ndarray, lo: int, hi: int, scratch_qdr: np.ndarray, scratch_dist: np.ndarray,
    fresh: np.ndarray, reached: np.ndarray,
) -> int:
    """The waypoint test of aircraft ``lo..hi-1`` at the start of a step."""
    nreached = 0
    for i in range(lo, hi):
        nreached += _check_waypoint(F, B, i, scratch_qdr, scratch_dist, fresh, reached)
    return nreached


@njit(cache=True, inline="always", error_model="numpy")
def _advance(
    F: np.ndarray,
    B: np.ndarray,
    n: int,
    dt: float,
    nsteps: int,
    check_first: bool,
    hold_speed: float,
    airborne_alt: float,
    scratch: tuple[np.ndarray, ...],
    cond: tuple[np.ndarray, ...],
    wind: tuple[np.ndarray, ...] | None,
    turns: tuple[()] | None,
    reso: tuple[()] | None,
    nblocks: int,
) -> tuple[int, int]:
    scratch_qdr, scratch_dist, fresh, reached = scratch
    nblocks = max(1, min(n, nblocks))
    counts = np.zeros(nblocks, dtype=np.int64)
    # Block b holds aircraft b*n//nblocks .. (b+1)*n//nblocks - 1. prange is a
    # plain loop in the serial kernel and splits the blocks over threads in
    # the parallel one; every block runs the same compiled code, so both give
    # the same bits. The threads meet after each step for the events.
    if check_first:
        for b in prange(nblocks):
            counts[b] = _check_range(F, B, b * n // nblocks, (b + 1) * n // nblocks, scratch_qdr, scratch_dist,
                                     fresh, reached)
        if counts.sum():
            return 0, STATUS_REACHED
    k = 0
    while k < nsteps:
        test_next = k + 1 < nsteps
        for b in prange(nblocks):
            counts[b] = _step_range(F, B, b * n // nblocks, (b + 1) * n // nblocks, dt, test_next, hold_speed,
                                    airborne_alt, scratch_qdr, scratch_dist, fresh, reached, wind, turns, reso)
        k += 1
        total = counts.sum()
        if total >= _NONFINITE_MARK:
            return k, STATUS_NONFINITE
        if cond[0].shape[0] and _conditions_fired(F, cond):
            return k, STATUS_CONDITION
        if total:
            return k, STATUS_REACHED
    return k, STATUS_DONE


@njit(cache=True, error_model="numpy")
def advance(
    F: np.ndarray, B: np.ndarray, n: int, dt: float, nsteps: int, check_first: bool, hold_speed: float,
    airborne_alt: float, scratch: tuple[np.ndarray, ...], cond: tuple[np.ndarray, ...],
    wind: tuple[np.ndarray, ...] | None, turns: tuple[()] | None, reso: tuple[()] | None,
) -> tuple[int, int]:
    """Advance all ``n`` aircraft by up to ``nsteps`` steps of ``dt`` seconds.

    Args:
        scratch: ``(qdr, dist, fresh, reached)`` per slot: ``fresh[i]`` tells
            that ``qdr/dist[i]`` hold this step's guidance for aircraft ``i``
            (the waypoint test computed them; Python clears it for aircraft
            whose leg it changed before resuming), ``reached[i]`` that the
            aircraft is at its waypoint.
        cond: the conditional commands' arrays (:meth:`Conditions.arrays`).
        wind: the wind field's arrays (:meth:`aamsim.traffic.wind.WindField.arrays`), None without wind.
        turns: ``()`` when some aircraft may fly at a turn speed (fly-turn waypoints), else None.
        reso: ``()`` when some aircraft may follow a conflict resolution (the ``asas`` flag), else None:
            without it the kernel is compiled without that part.

    Returns:
        ``(steps_done, status)``, status one of ``STATUS_*``.
    """
    return _advance(F, B, n, dt, nsteps, check_first, hold_speed, airborne_alt, scratch, cond, wind, turns, reso,
                    1)


@njit(cache=True, parallel=True, error_model="numpy")
def advance_parallel(
    F: np.ndarray, B: np.ndarray, n: int, dt: float, nsteps: int, check_first: bool, hold_speed: float,
    airborne_alt: float, scratch: tuple[np.ndarray, ...], cond: tuple[np.ndarray, ...],
    wind: tuple[np.ndarray, ...] | None, turns: tuple[()] | None, reso: tuple[()] | None, nblocks: int,
) -> tuple[int, int]:
    """:func:`advance` with the aircraft in ``nblocks`` blocks over Numba's threads (same results, bit for bit)."""
    return _advance(F, B, n, dt, nsteps, check_first, hold_speed, airborne_alt, scratch, cond, wind, turns, reso,
                    nblocks)


@njit(cache=True, inline="always", error_model="numpy")
def _advance_ranges(
    F: np.ndarray, B: np.ndarray, lo: np.ndarray, hi: np.ndarray, check: np.ndarray, dt: float, nsteps: int,
    hold_speed: np.ndarray, airborne_alt: np.ndarray, scratch: tuple[np.ndarray, ...], cond: tuple[np.ndarray, ...],
    turns: tuple[()] | None, reso: tuple[()] | None, counts: np.ndarray,
) -> tuple[int, int]:
    scratch_qdr, scratch_dist, fresh, reached = scratch
    nblocks = lo.shape[0]
    counts[:] = 0
    # As _advance, with the blocks given: each is a range of slots with its own settings and
    # its own waypoint test at the start (a range whose test already ran skips it).
    if check.any():
        for b in prange(nblocks):
            if check[b]:
                counts[b] = _check_range(F, B, lo[b], hi[b], scratch_qdr, scratch_dist, fresh, reached)
        if counts.sum():
            return 0, STATUS_REACHED
    k = 0
    while k < nsteps:
        test_next = k + 1 < nsteps
        for b in prange(nblocks):
            counts[b] = _step_range(F, B, lo[b], hi[b], dt, test_next, hold_speed[b], airborne_alt[b], scratch_qdr,
                                    scratch_dist, fresh, reached, None, turns, reso)
        k += 1
        total = counts.sum()
        if total >= _NONFINITE_MARK:
            return k, STATUS_NONFINITE
        if cond[0].shape[0] and _conditions_fired(F, cond):
            return k, STATUS_CONDITION
        if total:
            return k, STATUS_REACHED
    return k, STATUS_DONE


@njit(cache=True, error_model="numpy")
def advance_ranges(
    F: np.ndarray, B: np.ndarray, lo: np.ndarray, hi: np.ndarray, check: np.ndarray, dt: float, nsteps: int,
    hold_speed: np.ndarray, airborne_alt: np.ndarray, scratch: tuple[np.ndarray, ...], cond: tuple[np.ndarray, ...],
    turns: tuple[()] | None, reso: tuple[()] | None, counts: np.ndarray,
) -> tuple[int, int]:
    """:func:`advance` on the slot ranges ``lo[b] .. hi[b] - 1`` (no wind), each with its own settings.

    Args:
        check: per range, whether its waypoint test runs before the first step (``check_first``
            of :func:`advance`; False where the previous call already ran it).
        hold_speed, airborne_alt: per range, the holding-speed [m/s] and airborne [m] thresholds.
        cond: the conditional commands of every range, with slots into ``F``.
        counts: (out) per range, after a ``STATUS_REACHED`` return, how many of its aircraft reached
            their waypoint (0: nothing to do there); after a ``STATUS_NONFINITE`` one, at least
            ``2**40`` for a range with a non-finite state.

    Each aircraft is advanced by the same compiled code as in :func:`advance`, so the
    result is the same bit for bit as advancing each range alone.
    """
    return _advance_ranges(F, B, lo, hi, check, dt, nsteps, hold_speed, airborne_alt, scratch, cond, turns, reso,
                           counts)


@njit(cache=True, parallel=True, error_model="numpy")
def advance_ranges_parallel(
    F: np.ndarray, B: np.ndarray, lo: np.ndarray, hi: np.ndarray, check: np.ndarray, dt: float, nsteps: int,
    hold_speed: np.ndarray, airborne_alt: np.ndarray, scratch: tuple[np.ndarray, ...], cond: tuple[np.ndarray, ...],
    turns: tuple[()] | None, reso: tuple[()] | None, counts: np.ndarray,
) -> tuple[int, int]:
    """:func:`advance_ranges` with the ranges over Numba's threads (same results, bit for bit)."""
    return _advance_ranges(F, B, lo, hi, check, dt, nsteps, hold_speed, airborne_alt, scratch, cond, turns, reso,
                           counts)
