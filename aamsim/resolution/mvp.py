"""BlueSky's Modified Voltage Potential (MVP) conflict resolution: the settings and the arithmetic.

The formulas are BlueSky 1.1.1's (``traffic/asas/mvp.py``), written here from
their description; the service that applies them each cycle is
:mod:`aamsim.resolution.mvp_service` (``RESO MVP``).

For each conflict pair, seen from the ownship (both orders of a pair are
resolved, each by its own ownship), MVP pushes the ownship's velocity away
from the intruder's position at the closest point of approach (CPA):

* horizontally, along the miss-distance vector ``dcpa = drel + vrel tcpa``, by
  the intrusion ``rpz - |dcpa|`` spread over ``|tcpa|`` seconds. When the
  intruder is outside the (resolution-factor enlarged) protected zone, the
  push is enlarged so that the new relative track is tangent to the zone
  rather than cutting it (``rpz / cos(asin(rpz/d) - asin(|dcpa|/d))``).
  A head-on pair (``|dcpa| <= 10 m``) is pushed sideways, perpendicular to
  the line between the aircraft;
* vertically, by the vertical zone over the time to co-altitude (or the time
  to loss of separation when there is no vertical closure or that time is
  beyond the look-ahead), against the relative vertical speed. Without
  priority rules each aircraft takes half of it (both resolve).

Per aircraft, the pushes of all its pairs add up; the new velocity (the
current one plus the sum) gives the track, ground speed and vertical speed
that the resolution commands, limited to one or both of its horizontal
parts or to the vertical one (``RMETHH``, ``RMETHV``), capped to the
envelope.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# BlueSky's resolution-zone margins (asas_marh, asas_marv of its default.cfg; 1.01 in the code).
DEFAULT_FACTOR = 1.05
PRIORITY_CODES = ("FF1", "FF2", "FF3", "LAY1", "LAY2")
HORIZONTAL_OPTIONS = ("BOTH", "SPD", "HDG", "NONE", "ON", "OFF", "OF")
VERTICAL_OPTIONS = ("NONE", "ON", "OFF", "OF", "V/S")
_CRUISE_VS = 0.1  # m/s: below this an aircraft counts as cruising for the priority rules


@dataclass
class MVPSettings:
    """What the resolution may change and how much (BlueSky's MVP switches and factors)."""

    factor_h: float = DEFAULT_FACTOR  # RFACH: resolution zone = protected zone x this
    factor_v: float = DEFAULT_FACTOR  # RFACV
    horizontal: bool = True  # swresohoriz: horizontal resolutions only
    speed: bool = False  # swresospd: speed only (with horizontal)
    heading: bool = False  # swresohdg: heading only (with horizontal)
    vertical: bool = False  # swresovert: vertical resolutions only
    priority: bool = False  # PRIORULES ON/OFF
    priority_code: str = ""  # FF1, FF2, FF3, LAY1, LAY2
    zone_r_relative: bool = True  # the horizontal factor was set as a factor (RFACH), not a radius (RSZONER)
    zone_dh_relative: bool = True

    def set_horizontal(self, value: str) -> None:
        """RMETHH: ON/BOTH (speed and heading), SPD, HDG, OFF/NONE (no horizontal restriction)."""
        if value not in HORIZONTAL_OPTIONS:
            raise ValueError(f"RMETHH {value!r} not understood; use ON, BOTH, SPD, HDG, OFF or NONE")
        if value in ("ON", "BOTH"):
            self.horizontal, self.speed, self.heading, self.vertical = True, True, True, False
        elif value in ("OFF", "OF", "NONE"):
            # As BlueSky: the vertical switch is left as it is.
            self.horizontal, self.speed, self.heading = False, False, False
        elif value == "SPD":
            self.horizontal, self.speed, self.heading, self.vertical = True, True, False, False
        else:
            self.horizontal, self.speed, self.heading, self.vertical = True, False, True, False

    def set_vertical(self, value: str) -> None:
        """RMETHV: ON or V/S (vertical only), OFF/NONE (the horizontal switches are left as they are)."""
        if value not in VERTICAL_OPTIONS:
            raise ValueError(f"RMETHV {value!r} not understood; use ON, V/S, OFF or NONE")
        if value in ("ON", "V/S"):
            self.vertical, self.horizontal, self.speed, self.heading = True, False, False, False
        else:
            self.vertical = False

    def set_priority(self, on: bool, code: str) -> None:
        """PRIORULES ON/OFF code: the code must be one of :data:`PRIORITY_CODES` (as BlueSky, also with OFF)."""
        if code not in PRIORITY_CODES:
            raise ValueError(f"priority code {code!r} not understood; use one of {', '.join(PRIORITY_CODES)}")
        self.priority, self.priority_code = on, code

    def describe(self) -> str:
        if self.vertical:
            mode = "vertical only"
        elif not self.horizontal:
            mode = "horizontal and vertical"
        elif self.speed and not self.heading:
            mode = "speed only"
        elif self.heading and not self.speed:
            mode = "heading only"
        else:
            mode = "heading and speed"
        prio = f"priority {self.priority_code}" if self.priority else "no priority rules"
        return f"MVP: {mode}; RFACH {self.factor_h:g}, RFACV {self.factor_v:g}; {prio}"


@dataclass(frozen=True)
class PairGeometry:
    """Directed conflict pairs (ownship ``own``, intruder ``intr``, slots) and their state.

    ``drel``: the intruder's position relative to the ownship [m] (east, north,
    up); ``vrel``: its velocity relative to the ownship [m/s]; ``tcpa`` and
    ``tlos``: time to CPA and to loss of separation [s] (conflict detection's).
    """

    own: np.ndarray
    intr: np.ndarray
    drel: np.ndarray  # (m, 3)
    vrel: np.ndarray  # (m, 3)
    tcpa: np.ndarray
    tlos: np.ndarray


# A pair whose push BlueSky's arithmetic makes infinite or NaN (aircraft at one spot, a time to
# CPA or to resolve of zero: two aircraft with the same track and speed have a time to CPA of
# exactly 0) is resolved over this time instead [s]: one detection cycle (DT ASAS's default).
DEGENERATE_TIME_S = 1.0
# A finite push beyond this [m/s] (only a subnormal time gets there) is clipped, so that the
# pushes of many pairs add up without overflowing into inf - inf = NaN.
MAX_PUSH_MPS = 1e100


def mvp_pairs(g: PairGeometry, rpz_m: float, hpz_m: float, dtlook_s: float) -> tuple[np.ndarray, np.ndarray]:
    """MVP's push on each pair's relative velocity (m, 3) and the time to resolve vertically (m,).

    ``rpz_m`` and ``hpz_m`` are the resolution zone (the protected zone times
    the resolution factors). The push is the intruder's view: the ownship's
    velocity changes by minus it (see :func:`combine`). Every push is finite
    (see :func:`_mvp_one`).
    """
    drel, vrel, tcpa, tlos = g.drel, g.vrel, g.tcpa, g.tlos
    m = tcpa.shape[0]
    dv = np.zeros((m, 3))
    tsol = np.zeros(m)
    for k in range(m):
        own, intr = int(g.own[k]), int(g.intr[k])
        dv[k], tsol[k] = _mvp_one(drel[k], vrel[k], float(tcpa[k]), float(tlos[k]), rpz_m, hpz_m, dtlook_s)
        horizontal_ok = math.isfinite(dv[k, 0]) and math.isfinite(dv[k, 1])
        vertical_ok = math.isfinite(dv[k, 2]) and math.isfinite(tsol[k])
        if not (horizontal_ok and vertical_ok):
            # Only the part BlueSky's arithmetic left non-finite is replaced.
            side = 1.0 if own < intr else -1.0
            fix, fix_tsol = _mvp_degenerate(drel[k], vrel[k], float(tcpa[k]), float(tlos[k]), rpz_m, hpz_m,
                                            dtlook_s, side)
            if not horizontal_ok:
                dv[k, :2] = fix[:2]
            if not vertical_ok:
                dv[k, 2], tsol[k] = fix[2], fix_tsol
    np.clip(dv, -MAX_PUSH_MPS, MAX_PUSH_MPS, out=dv)
    return dv, tsol


def _mvp_one(drel: np.ndarray, vrel: np.ndarray, tcpa: float, tlos: float, rpz: float, hpz: float,
             dtlook: float) -> tuple[np.ndarray, float]:
    """One directed pair (see :func:`mvp_pairs`); IEEE arithmetic as BlueSky's NumPy scalars (x/0 is inf)."""
    # NumPy scalars: co-located aircraft give inf and NaN, as in BlueSky, not an exception;
    # mvp_pairs then resolves the pair with _mvp_degenerate.
    dx, dy, dz = np.float64(drel[0]), np.float64(drel[1]), float(drel[2])
    dist = np.float64(math.hypot(dx, dy))
    cx, cy = dx + vrel[0] * tcpa, dy + vrel[1] * tcpa  # miss-distance vector at CPA
    dabs = math.hypot(cx, cy)
    intrusion = rpz - dabs
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if dabs <= 10.0:
            # Head-on: push perpendicular to the line between the aircraft.
            dabs = 10.0
            cx, cy = dy / dist * dabs, -dx / dist * dabs
        t = np.float64(abs(tcpa)) * dabs
        if rpz < dist and dabs < dist:
            # Outside the zone: aim at the tangent to it, not at its edge at CPA.
            erratum = math.cos(math.asin(rpz / dist) - math.asin(dabs / dist))
            push = rpz / erratum - dabs
        else:
            push = intrusion
        dv1 = np.float64(push * cx) / t
        dv2 = np.float64(push * cy) / t
        dvz = float(vrel[2])
        if abs(dvz) > 0.0:
            iv, tsol = hpz, abs(dz / dvz)
        else:
            iv, tsol = hpz - abs(dz), tlos
        if tsol > dtlook:
            iv, tsol = hpz, tlos
        dv3 = np.float64(iv) / np.float64(tsol)
        if abs(dvz) > 0.0:
            dv3 = dv3 * (-dvz / abs(dvz))  # the faster climber or descender moderates
    return np.array([dv1, dv2, dv3]), float(tsol)


def _mvp_degenerate(drel: np.ndarray, vrel: np.ndarray, tcpa: float, tlos: float, rpz: float, hpz: float,
                    dtlook: float, side: float) -> tuple[np.ndarray, float]:
    """A pair whose BlueSky push is not finite (BlueSky flies its aircraft into NaN; aamsim does not).

    The same push as :func:`_mvp_one`, with three changes that only apply where
    BlueSky divides by zero: times to CPA and to resolve shorter than
    :data:`DEGENERATE_TIME_S` (zero, for two aircraft with the same velocity)
    take that time; the sideways push of a head-on pair at one horizontal spot
    is perpendicular to the relative velocity (east or west, by ``side``, when
    there is none, so that the two aircraft of the pair part); and products
    that overflow are clipped to :data:`MAX_PUSH_MPS`.
    """
    dx, dy, dz = float(drel[0]), float(drel[1]), float(drel[2])
    ux, uy = float(vrel[0]), float(vrel[1])
    dist = math.hypot(dx, dy)
    cx, cy = dx + ux * tcpa, dy + uy * tcpa
    dabs = math.hypot(cx, cy)
    if not math.isfinite(dabs):
        cx, cy, dabs = dx, dy, dist
    intrusion = rpz - dabs
    if dabs <= 10.0:
        speed = math.hypot(ux, uy)
        if dist > 0.0:
            lx, ly = dx / dist, dy / dist
        elif speed > 0.0:
            lx, ly = ux / speed, uy / speed
        else:
            lx, ly = 0.0, side  # the pair's line taken north-south: pushed east and west
        dabs = 10.0
        cx, cy = ly * dabs, -lx * dabs
    if rpz < dist and dabs < dist:
        erratum = math.cos(math.asin(rpz / dist) - math.asin(dabs / dist))
        push = rpz / erratum - dabs
    else:
        push = intrusion
    push = _clipped(push)  # a tangent nearly along the line of sight: a huge erratum factor
    t = max(abs(tcpa), DEGENERATE_TIME_S) * dabs
    dv1 = _clipped(push * cx / t)
    dv2 = _clipped(push * cy / t)
    dvz = float(vrel[2])
    if abs(dvz) > 0.0:
        iv, tsol = hpz, abs(dz / dvz) if math.isfinite(dz / dvz) else math.inf
    else:
        iv, tsol = hpz - abs(dz), tlos
    if tsol > dtlook:
        iv, tsol = hpz, tlos
    if not abs(tsol) >= DEGENERATE_TIME_S:  # also NaN
        tsol = math.copysign(DEGENERATE_TIME_S, tsol) if math.isfinite(tsol) else DEGENERATE_TIME_S
    dv3 = _clipped(iv / tsol)
    if abs(dvz) > 0.0:
        dv3 = -dv3 if dvz > 0.0 else dv3
    return np.array([dv1, dv2, dv3]), float(tsol)


def _clipped(x: float) -> float:
    """``x`` within +-:data:`MAX_PUSH_MPS` (an overflow to inf included; NaN, no push, is 0)."""
    if math.isnan(x):
        return 0.0
    return min(max(x, -MAX_PUSH_MPS), MAX_PUSH_MPS)


def _priority_share(code: str, vs_own: float, vs_intr: float, push: np.ndarray) -> tuple[bool, np.ndarray]:
    """Whether the ownship takes ``push`` under a priority code, and the push as the code shapes it.

    BlueSky's applyprio seen from the ownship: FF1 both resolve (vertical
    halved); FF2 a cruising aircraft keeps its path against a climbing or
    descending one; FF3 the reverse, the cruising one resolving horizontally;
    LAY1 and LAY2 as FF2 and FF3 but horizontal only.
    """
    p = push.copy()
    own_cruise = abs(vs_own) < _CRUISE_VS and abs(vs_intr) > _CRUISE_VS
    intr_cruise = abs(vs_intr) < _CRUISE_VS and abs(vs_own) > _CRUISE_VS
    if code in ("FF1", "FF2"):
        p[2] *= 0.5
        return not (code == "FF2" and own_cruise), p
    if code == "FF3":
        if own_cruise or intr_cruise:
            p[2] = 0.0
            return own_cruise, p
        p[2] *= 0.5
        return True, p
    p[2] = 0.0  # LAY1, LAY2
    if code == "LAY1":
        return not own_cruise, p
    return not intr_cruise, p


def combine(n: int, g: PairGeometry, push: np.ndarray, tsol: np.ndarray, settings: MVPSettings, vs: np.ndarray,
            no_reso: np.ndarray, reso_off: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per aircraft: the sum of its pairs' velocity changes (n, 3) and its shortest time to resolve vertically.

    ``no_reso``: aircraft that nobody avoids (NORESO); ``reso_off``: aircraft
    that avoid nobody (RESOOFF). Aircraft in no pair get zero and 1e9 s.
    """
    dv = np.zeros((n, 3))
    tsolv = np.full(n, 1e9)
    for k in range(g.own.shape[0]):
        i, j = int(g.own[k]), int(g.intr[k])
        tsolv[i] = min(tsolv[i], tsol[k])
        if settings.priority:
            takes, p = _priority_share(settings.priority_code, float(vs[i]), float(vs[j]), push[k])
        else:
            takes, p = True, push[k].copy()
            p[2] *= 0.5  # both aircraft resolve: each takes half the vertical push
        if takes:
            dv[i] -= p
        if no_reso[j]:
            dv[i] += p  # as BlueSky: the shaped push is given back, whether it was taken or not
    dv[reso_off] = 0.0
    return dv, tsolv


@dataclass(frozen=True)
class OwnState:
    """What the resolution reads of every aircraft (view arrays, SI, degrees)."""

    gseast: np.ndarray
    gsnorth: np.ndarray
    vs: np.ndarray
    trk: np.ndarray
    gs: np.ndarray
    alt: np.ndarray
    selalt: np.ndarray
    ap_vs: np.ndarray
    vmin: np.ndarray
    vmax: np.ndarray
    vsmin: np.ndarray
    vsmax: np.ndarray


def commands(s: OwnState, dv: np.ndarray, tsolv: np.ndarray, settings: MVPSettings,
             dtlook_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Track [deg], ground speed, vertical speed [m/s] and altitude [m] the resolution commands to every aircraft.

    As BlueSky: the new velocity is the current one plus ``dv``, limited to
    the allowed directions; the ground speed is capped to the envelope's
    speeds (whatever their kind) and the vertical speed to its rates. The
    altitude is the selected one for horizontal resolutions; otherwise the one
    reached at the resolution's vertical speed in the time to resolve, unless
    the selected altitude lies on the way (then it stops there).
    """
    ve, vn, vz = s.gseast + dv[:, 0], s.gsnorth + dv[:, 1], s.vs + dv[:, 2]
    new_trk = np.arctan2(ve, vn) * 180 / np.pi % 360  # BlueSky's rounding (np.degrees rounds differently)
    new_gs = np.sqrt(ve * ve + vn * vn)
    if settings.horizontal:
        if settings.speed and not settings.heading:
            trk, gs, vs = s.trk, new_gs, s.vs
        elif settings.heading and not settings.speed:
            trk, gs, vs = new_trk, s.gs, s.vs
        else:
            trk, gs, vs = new_trk, new_gs, s.vs
    elif settings.vertical:
        trk, gs, vs = s.trk, s.gs, vz
    else:
        trk, gs, vs = new_trk, new_gs, vz
    gs = np.maximum(s.vmin, np.minimum(s.vmax, gs))
    vs = np.maximum(s.vsmin, np.minimum(s.vsmax, vs))
    if settings.horizontal:
        return np.array(trk, dtype=np.float64), gs, vs, np.array(s.selalt, dtype=np.float64)
    with np.errstate(invalid="ignore", over="ignore"):
        reach = vs * tsolv + s.alt
        sign_dvs = np.sign(vs - s.ap_vs * np.sign(s.selalt - s.alt))
        sign_alt = np.sign(reach - s.selalt)
    alt = np.where((sign_dvs == 0) | (sign_dvs == sign_alt), reach, s.selalt)
    resolving = (tsolv < dtlook_s) & (np.abs(dv[:, 2]) > 0.0)
    alt[resolving] = reach[resolving]
    return np.array(trk, dtype=np.float64), gs, vs, alt
