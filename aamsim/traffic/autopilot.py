"""Event-driven autopilot logic: activating legs and planning VNAV.

The continuous guidance (steering to the active waypoint, speed and altitude
tracking) runs every step in the Numba kernel (:mod:`aamsim.traffic.kernel`).
What happens only at events lives here, per aircraft, in Python: a waypoint
is reached and the next leg begins, a DIRECT/ADDWPT re-activates a leg, VNAV
computes where to start climbing or descending. The behaviour follows
BlueSky's FMS: fly-by turn anticipation R*tan(dpsi/2) at the default bank
angle, speed constraints that apply from their waypoint on and are
anticipated by the distance needed to accelerate, climbs started at once,
descents at 3000 ft per 10 NM ending at the constraint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from aamsim import aero
from aamsim.geo import degto180, kwik_qdrdist, qdrdist
from aamsim.traffic import fields as f
from aamsim.traffic.route import Route, TurnSpec, Waypoint
from aamsim.traffic.traffic import Traffic
from aamsim.units import FT, G0, NM

VNAV_STEEPNESS = 3000.0 * FT / (10.0 * NM)  # descent gradient [m/m]
_EPS_ALT_ABOVE = 2.0 * FT  # deadband before a descent is planned [m]
_EPS_ALT_BELOW = 9.9 * FT  # deadband before a climb is planned [m]


def turn_distance(tas: float, bank_rad: float, qdr_in: float, qdr_out: float, flyby: bool) -> float:
    """Fly-by anticipation distance [m] before a waypoint (0 for fly-over).

    The turn radius follows from the speed and bank angle, R = V^2 / (g tan phi);
    the turn starts R*tan(dpsi/2) before the waypoint.
    """
    return plan_turn(tas, 0.0, bank_rad, qdr_in, qdr_out, flyby, None).distance_m


FLYTURN_DEFAULT_BANK_DEG = 25.0  # BlueSky's bank for a turn given by its speed alone


@dataclass(frozen=True)
class Turn:
    """The turn at a waypoint, as BlueSky's ``calcturn`` plans it (SI units).

    Attributes:
        distance_m: how far before the waypoint the turn starts (0: fly over it).
        radius_m: turn radius.
        bank_rad: bank angle flown while this waypoint is active.
        speed_cas: CAS [m/s] to fly a fly-turn at (NaN for fly-by and fly-over).
    """

    distance_m: float
    radius_m: float
    bank_rad: float
    speed_cas: float


def plan_turn(tas: float, alt: float, bankdef_rad: float, qdr_in: float, qdr_out: float, flyby: bool,
              spec: TurnSpec | None) -> Turn:
    """Plan the turn at a waypoint from the speed now and what was given for it.

    Fly-by and fly-over turns (``spec`` None), and fly-turns with nothing given,
    bank at the default angle at the current speed. A fly-turn given one value
    keeps the current speed (the speed alone: 25 deg bank); two given values
    fix the third. Radius, bank and rate are related by R = V^2 / (g tan phi)
    and V = R * omega. As in BlueSky, a given turn speed (a CAS) enters these
    relations as it is; a speed that follows from the others is a TAS,
    converted to CAS at ``alt``. (BlueSky's ``calcturn`` also takes arctan's
    radians for degrees and a rate in deg/s for rad/s: docs/bluesky-differences.md.)
    """
    given = spec.given() if spec is not None else ()
    bank = bankdef_rad
    speed = tas
    radius = math.nan
    if spec is not None and given:
        g = set(given)
        bank = math.radians(spec.bank_deg) if "bank" in g else math.nan
        radius = spec.radius_m if "radius" in g else math.nan
        speed = spec.speed_cas if "speed" in g else (tas if len(g) == 1 else math.nan)
        rate = math.radians(spec.rate_dps) if "rate" in g else math.nan
        if g == {"speed"}:
            bank = math.radians(FLYTURN_DEFAULT_BANK_DEG)
        elif "rate" in g and "radius" in g:
            speed = rate * radius
        elif "rate" in g and "bank" in g:
            speed = G0 * math.tan(bank) / rate
        elif "radius" in g and "bank" in g:
            speed = math.sqrt(G0 * radius * math.tan(bank))
        if "rate" in g and math.isnan(radius):
            radius = speed / rate
        if math.isnan(bank):
            bank = math.atan(rate * speed / G0) if "rate" in g else math.atan(speed * speed / (radius * G0))
    if math.isnan(radius):
        radius = speed * speed / (G0 * math.tan(bank))
    if spec is None and not flyby or spec is not None and not given:
        distance = 0.0
    else:
        distance = abs(radius * math.tan(math.radians(0.5 * abs(degto180(qdr_in % 360.0 - qdr_out % 360.0)))))
    if spec is None:
        speed_cas = math.nan
    elif "speed" in given:
        speed_cas = spec.speed_cas
    else:
        speed_cas = float(aero.tas2cas(speed, alt))
    return Turn(distance, radius, bank, speed_cas)


def waypoint_speed_cas(spd: float, is_mach: bool, alt: float) -> float:
    """A waypoint speed constraint as CAS [m/s] (Mach converted at ``alt``)."""
    if math.isnan(spd):
        return math.nan
    return aero.mach2cas(spd, alt) if is_mach else spd


def compute_vnav(traffic: Traffic, i: int, toalt: float, xtoalt: float) -> None:
    """Plan the vertical profile of the active leg of aircraft ``i``.

    Args:
        toalt: next altitude constraint along the route [m] (NaN: none).
        xtoalt: distance from the active waypoint to that constraint [m].
    """
    F, B = traffic.F, traffic.B
    if math.isnan(toalt) or not B[f.B_SWVNAV, i]:
        F[f.DIST2VS, i] = -math.inf  # never start a climb or descent on this leg
        return
    alt = F[f.ALT, i]
    gs = F[f.GS, i]
    tas = F[f.TAS, i]
    # Like BlueSky, plan with the guidance distance of the last step (DIST2WP),
    # which right after creation is its initial -999 m: a leg activated in the
    # creation step therefore climbs at the steepest rate. See
    # docs/bluesky-differences.md ("kept on purpose").
    if alt > toalt + _EPS_ALT_ABOVE:
        # Above the constraint: stop any climb at once, then descend.
        if F[f.VS, i] > 0.0001:
            F[f.SELALT, i] = alt
        F[f.WP_NEXTALTCO, i] = toalt
        F[f.WP_XTOALT, i] = xtoalt
        gs_eff = gs + (tas if gs < 0.2 * tas else 0.0)
        if B[f.B_SWTOD, i]:
            _, dist = kwik_qdrdist(F[f.LAT, i], F[f.LON, i], F[f.WP_LAT, i], F[f.WP_LON, i])
            dist2wp = float(dist)
            F[f.DIST2WP, i] = dist2wp
            descdist = abs(alt - toalt) / VNAV_STEEPNESS
            F[f.DIST2VS, i] = descdist - xtoalt
            if dist2wp - 1.02 * F[f.WP_TURNDIST, i] < F[f.DIST2VS, i]:
                # Late: use the whole remaining leg to get down.
                t2go = dist2wp / max(0.01, gs)
                F[f.WP_VS, i] = (alt - toalt) / max(0.01, t2go)
            elif xtoalt < descdist:
                F[f.WP_VS, i] = -VNAV_STEEPNESS * gs_eff
            else:
                F[f.WP_VS, i] = 0.0
        else:
            steep = (alt - toalt) / max(0.01, F[f.DIST2WP, i] + xtoalt)
            F[f.WP_VS, i] = -abs(steep) * gs_eff
            F[f.DIST2VS, i] = 99999.0
    elif alt < toalt - _EPS_ALT_BELOW:
        # Below the constraint: stop any descent at once, then climb as early as possible.
        if F[f.VS, i] < -0.0001:
            F[f.SELALT, i] = alt
        F[f.WP_NEXTALTCO, i] = toalt
        F[f.WP_XTOALT, i] = xtoalt
        F[f.DIST2VS, i] = 99999.0
        t2go = max(0.1, F[f.DIST2WP, i] + xtoalt) / max(0.01, gs)
        if B[f.B_SWTOC, i]:
            steep = VNAV_STEEPNESS
        else:
            steep = (alt - toalt) / max(0.01, F[f.DIST2WP, i] + xtoalt)
        F[f.WP_VS, i] = max(steep * gs, (toalt - alt) / t2go)
    else:
        F[f.DIST2VS, i] = -math.inf


def _plan_active_turn(traffic: Traffic, i: int, wp: Waypoint, qdr: float) -> None:
    """The turn at the active waypoint ``wp``, reached along bearing ``qdr``: anticipation, bank, turn speed."""
    F, B = traffic.F, traffic.B
    next_qdr = F[f.WP_NEXTQDR, i]
    turn = plan_turn(F[f.TAS, i], F[f.ALT, i], F[f.BANKDEF, i], qdr, qdr if math.isnan(next_qdr) else next_qdr,
                     wp.flyby, wp.turn)
    F[f.WP_TURNDIST, i] = turn.distance_m
    F[f.TURNPHI, i] = turn.bank_rad
    F[f.WP_TURNSPD, i] = turn.speed_cas
    B[f.B_WP_FLYBY, i] = wp.flyby or wp.turn is not None  # the turn is anticipated by WP_TURNDIST


def _find_next_turn(traffic: Traffic, i: int) -> None:
    """The first fly-turn waypoint from the active one on, whose turn speed VNAV slows down for."""
    F, B = traffic.F, traffic.B
    route = traffic.routes[i]
    k = route.next_turn_index()
    B[f.B_HAS_NEXTTURN, i] = k >= 0
    if k < 0:
        return
    traffic.turn_speeds_used = True
    wp = route.waypoints[k]
    turn = plan_turn(F[f.TAS, i], F[f.ALT, i], F[f.BANKDEF, i], 0.0, 0.0, False, wp.turn)
    F[f.WP_NEXTTURNLAT, i] = wp.lat
    F[f.WP_NEXTTURNLON, i] = wp.lon
    F[f.WP_NEXTTURNSPD, i] = turn.speed_cas
    F[f.WP_NEXTTURNRAD, i] = turn.radius_m


def activate_waypoint(traffic: Traffic, i: int, index: int) -> None:
    """Make waypoint ``index`` of aircraft ``i``'s route the active one (DIRECT).

    Switches LNAV on, sets up the leg (direction, length, fly-by distance) and
    plans VNAV toward the next altitude constraint.
    """
    F, B = traffic.F, traffic.B
    route = traffic.routes[i]
    route.iactwp = index
    wp = route.waypoints[index]
    F[f.WP_LAT, i] = wp.lat
    F[f.WP_LON, i] = wp.lon
    B[f.B_WP_LASTWP, i] = index == len(route) - 1
    F[f.WP_NEXTQDR, i] = route.next_leg_qdr()
    _find_next_turn(traffic, i)
    route.plan()
    F[f.WP_XTOALT, i] = wp.xtoalt
    F[f.WP_NEXTALTCO, i] = wp.toalt
    compute_vnav(traffic, i, wp.toalt, wp.xtoalt)
    spd_alt = F[f.ALT, i] if math.isnan(wp.alt) else wp.alt
    F[f.WP_NEXTSPD, i] = waypoint_speed_cas(wp.spd, wp.spd_mach, spd_alt)
    qdr, dist = qdrdist(F[f.LAT, i], F[f.LON, i], wp.lat, wp.lon)
    F[f.WP_CURLEGDIR, i] = qdr
    F[f.WP_CURLEGLEN, i] = dist
    _plan_active_turn(traffic, i, wp, qdr)
    B[f.B_SWLNAV, i] = True


def pass_waypoint(traffic: Traffic, i: int) -> tuple[list[tuple[str, Any]], bool]:
    """Aircraft ``i`` has reached its active waypoint: begin the next leg.

    Returns:
        The stack commands attached to the passed waypoint (AT ... DO) with
        the source of the AT line that stored each (None if unknown), and
        whether it was the last waypoint of the route (LNAV and VNAV are then
        switched off and the aircraft flies on along its track).
    """
    F, B = traffic.F, traffic.B
    route = traffic.routes[i]
    passed = route.waypoints[route.iactwp] if 0 <= route.iactwp < len(route) else None
    commands: list[tuple[str, Any]] = []
    if passed is not None:
        sources = passed.stack_sources + [None] * (len(passed.stack) - len(passed.stack_sources))
        commands = list(zip(passed.stack, sources))
    # Speeds are "from" speeds: the one of the waypoint we pass applies now.
    F[f.WP_SPD, i] = F[f.WP_NEXTSPD, i]
    F[f.WP_SPDCON, i] = F[f.WP_NEXTSPD, i]
    if B[f.B_WP_LASTWP, i]:
        B[f.B_SWLNAV, i] = False
        B[f.B_SWVNAV, i] = False
        B[f.B_SWVNAVSPD, i] = False
        return commands, True
    lnav_on = route.iactwp < len(route) - 1
    if lnav_on:
        route.iactwp += 1
    wp = route.waypoints[route.iactwp]
    B[f.B_WP_LASTWP, i] = route.iactwp == len(route) - 1
    F[f.WP_NEXTQDR, i] = route.next_leg_qdr()
    _find_next_turn(traffic, i)
    next_spd = waypoint_speed_cas(wp.spd, wp.spd_mach, F[f.ALT, i])
    if not lnav_on and B[f.B_SWLNAV, i]:
        B[f.B_SWLNAV, i] = False
        if B[f.B_SWVNAVSPD, i] and not math.isnan(next_spd):
            F[f.SELSPD, i] = next_spd
            B[f.B_SELSPD_MACH, i] = False
    B[f.B_SWVNAV, i] = B[f.B_SWVNAV, i] and B[f.B_SWLNAV, i]
    F[f.WP_NEXTSPD, i] = next_spd
    F[f.WP_LAT, i] = wp.lat
    F[f.WP_LON, i] = wp.lon
    qdr, dist = qdrdist(F[f.LAT, i], F[f.LON, i], wp.lat, wp.lon)
    F[f.DIST2WP, i] = dist
    F[f.WP_CURLEGDIR, i] = qdr
    F[f.WP_CURLEGLEN, i] = dist
    if not math.isnan(wp.alt):
        F[f.WP_NEXTALTCO, i] = wp.alt
        F[f.WP_XTOALT, i] = 0.0
    else:
        F[f.WP_NEXTALTCO, i] = wp.toalt
        F[f.WP_XTOALT, i] = wp.xtoalt
    if B[f.B_SWVNAVSPD, i] and not math.isnan(F[f.WP_SPD, i]):
        F[f.SELSPD, i] = F[f.WP_SPD, i]
        B[f.B_SELSPD_MACH, i] = False
    # The turn speed of the waypoint passed holds until the aircraft is on the new leg.
    F[f.WP_OLDTURNSPD, i] = F[f.WP_TURNSPD, i]
    _plan_active_turn(traffic, i, wp, qdr)
    B[f.B_TURNTONEXTWP, i] = False
    compute_vnav(traffic, i, wp.toalt, F[f.WP_XTOALT, i])
    return commands, False


def nearest_active_index(traffic: Traffic, i: int) -> int:
    """Best waypoint to fly to when LNAV is switched on (BlueSky's ``findact``).

    The nearest waypoint not behind the current active one; the one after it
    when the aircraft cannot turn onto it before getting there.
    """
    route: Route = traffic.routes[i]
    F = traffic.F
    n = len(route)
    if n <= 1:
        return n - 1
    lat, lon, coslat = F[f.LAT, i], F[f.LON, i], F[f.COSLAT, i]
    best, best_d2 = 0, math.inf
    dxs, dys = [], []
    for k, wp in enumerate(route.waypoints):
        dy = wp.lat - lat
        dx = (wp.lon - lon) * coslat
        dxs.append(dx)
        dys.append(dy)
        d2 = dx * dx + dy * dy
        if d2 < best_d2:
            best, best_d2 = k, d2
    near = max(route.iactwp, best)
    if near + 1 < n:
        qdr = math.degrees(math.atan2(dxs[near], dys[near]))
        delhdg = abs(degto180(F[f.TRK, i] - qdr))
        tas = max(0.01, F[f.TAS, i])
        time_turn = tas * math.radians(delhdg) / (G0 * math.tan(F[f.BANKDEF, i]))
        time_straight = math.sqrt(dxs[near] ** 2 + dys[near] ** 2) * 60.0 * NM / tas
        if time_turn > time_straight:
            near += 1
    return near
