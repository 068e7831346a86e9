"""DAA resolutions by heading and vertical speed: bands, preferred direction, coordination and recovery.

:class:`~aamsim.resolution.daa.DetectAndAvoid` resolves by ground speed; this
module adds the other two manoeuvre variables DAIDALUS computes guidance for
(its DO-365 configurations give bands in horizontal direction, horizontal
speed, vertical speed and altitude, each with recovery bands):

* **bands** (:meth:`AxisResolver.bands`): the tracks [deg] (at the ground speed of
  now) and the vertical speeds [m/s] (horizontal motion kept) that lose well
  clear within the look-ahead;
* **resolutions** (:meth:`AxisResolver.resolve`): per direction (right/left, up/down),
  the conflict-free value closest to the current one, kept a margin inside its
  band, within the turn limit (180 deg each way, DAIDALUS's DO-365 setting) or
  the vertical-speed limits (and the altitude floor and ceiling over the
  look-ahead). Of the two, the **preferred direction**: the one kept from the
  aircraft's previous resolution unless the other is closer by more than the
  persistence threshold (DAIDALUS's ``persistence_preferred_*``), else the
  direction given by implicit coordination with the most urgent intruder
  when it has a resolution, else the closer one;
* **implicit coordination**: both aircraft of a pair compute the same sense
  from the pair's shared geometry, so that their manoeuvres add up instead of
  cancelling. Horizontally, with ``s`` the ownship's position relative to the
  intruder and ``v`` the relative velocity, ``eps = sign(s x v)`` is the same
  for both (``(-s) x (-v) = s x v``); each turns the way that grows ``eps (s x v)``
  (a turn changes ``s x v`` by ``s x dv``; both changes have the sign ``eps``, so
  the miss distance grows on the side it already lies). A head-on pair
  (``s x v = 0``) takes ``eps = +1``: both turn right. Vertically the aircraft
  above climbs and the one below descends; at one altitude the callsign that
  sorts first climbs;
* **recovery** (:meth:`AxisResolver.recovery`): when no value of the axis is
  conflict-free (saturated bands), DAIDALUS's recovery bands: of the values that
  stay clear of the recovery volume (the NMAC distances) for
  ``recovery_lookahead_s``, the one that regains well clear soonest (ties: closest
  to the current value); none: no resolution.

Facts and formulas are from the DAIDALUS reference manual and its DO-365
configuration files (nasa/daidalus), and Muñoz et al., DASC 2015; no code was copied.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aamsim.conflicts.axis_bands import pair_hdg_bands, pair_vs_bands, velocity_intervals
from aamsim.conflicts.service import TrafficSnapshot
from aamsim.resolution.daa import isotropic_pairs
from aamsim.resolution.state import KinematicState, geometry_of

if TYPE_CHECKING:
    from aamsim.resolution.daa import DetectAndAvoid

HDG, VS, GS = "hdg", "vs", "gs"
RIGHT_UP, LEFT_DOWN = 1, -1


@dataclass(frozen=True)
class AxisBands:
    """Conflict bands of one axis for some aircraft: rows (slot, lo, hi), disjoint and sorted per slot.

    Headings are degrees in [0, 360] (a band across north is two rows); vertical speeds m/s
    within ``vmin``, ``vmax`` (per traffic slot).
    """

    axis: str
    slot: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    vmin: np.ndarray
    vmax: np.ndarray

    def of(self, slot: int) -> list[tuple[float, float]]:
        sel = self.slot == slot
        return list(zip(self.lo[sel].tolist(), self.hi[sel].tolist()))

    def conflicts(self, slot: int, x: float) -> bool:
        """Whether value ``x`` of ``slot`` lies in a conflict band (headings taken modulo 360)."""
        if self.axis == HDG:
            x = x % 360.0
        return any(lo <= x <= hi for lo, hi in self.of(slot))


@dataclass(frozen=True)
class AxisResolution:
    """One aircraft's resolution on one axis (``value`` NaN: none)."""

    axis: str
    value: float  # track [deg] or vertical speed [m/s]
    direction: int  # RIGHT_UP or LEFT_DOWN (0: recovery picked either)
    recovery: bool  # from the recovery bands (no conflict-free value)


def _free_linear(bands: list[tuple[float, float]], lo: float, hi: float) -> list[tuple[float, float, bool, bool]]:
    """Conflict-free intervals of [lo, hi] with flags: does each end border a conflict band."""
    out: list[tuple[float, float, bool, bool]] = []
    start, start_conf = lo, False
    for a, b in bands:
        if a > start:
            out.append((start, a, start_conf, True))
        if b >= start:
            start, start_conf = b, True
    if start < hi:
        out.append((start, hi, start_conf, False))
    return out


def linear_directions(bands: list[tuple[float, float]], lo: float, hi: float, x0: float,
                      margin: float) -> tuple[float, float]:
    """Closest conflict-free values at or above and at or below ``x0`` (NaN: none), ``margin`` inside bands."""
    up, down = math.nan, math.nan
    for a, b, ca, cb in _free_linear(bands, lo, hi):
        a2, b2 = a + (margin if ca else 0.0), b - (margin if cb else 0.0)
        if a2 > b2:
            a2 = b2 = 0.5 * (a + b)  # narrower than two margins: its middle
        if b2 >= x0 and (math.isnan(up) or max(a2, x0) < up):
            up = max(a2, x0)
        if a2 <= x0 and (math.isnan(down) or min(b2, x0) > down):
            down = min(b2, x0)
    return up, down


def heading_directions(bands: list[tuple[float, float]], h0: float, margin: float,
                       max_turn: float) -> tuple[float, float]:
    """Smallest right and left turns [deg] from ``h0`` to a conflict-free track (NaN: none within ``max_turn``)."""
    rel: list[tuple[float, float]] = []
    for a, b in bands:  # bands relative to h0, in [0, 360), split where they cross h0
        ra, rb = (a - h0) % 360.0, (b - h0) % 360.0
        if b - a >= 360.0 - 1e-9:
            return math.nan, math.nan
        if ra <= rb:
            rel.append((ra, rb))
        else:
            rel += [(ra, 360.0), (0.0, rb)]
    rel.sort()
    up, _ = linear_directions(rel, 0.0, 360.0, 0.0, margin)
    right = up if not math.isnan(up) and up <= max_turn else math.nan
    # Turning left by d reaches relative value 360 - d: the highest free value below 360.
    _, top = linear_directions(rel, 0.0, 360.0, 360.0, margin)
    left = 360.0 - top if not math.isnan(top) and 360.0 - top <= max_turn else math.nan
    return right, left


@dataclass
class AxisResolver:
    """Heading and vertical-speed resolutions with DAIDALUS's direction logic (see the module docstring)."""

    daa: DetectAndAvoid
    preferred: dict[tuple[str, str], int] = field(default_factory=dict)  # (callsign, axis) -> last direction

    def forget(self, acid: str) -> None:
        for axis in (HDG, VS, GS):
            self.preferred.pop((acid, axis), None)

    # ---------------------------------------------------------------- ranges
    def vs_range(self, sim: KinematicState) -> tuple[np.ndarray, np.ndarray]:
        """Per aircraft, the vertical speeds [m/s] a resolution may fly: the envelope, the limit, and no
        crossing of the altitude floor or ceiling within the look-ahead."""
        p, view = self.daa.params, sim.view
        alt = np.asarray(view.alt, dtype=np.float64)
        t = p.lookahead_s
        lo = np.maximum(np.maximum(np.asarray(view.vsmin, dtype=np.float64), -p.vs_max_mps), (p.alt_min_m - alt) / t)
        hi = np.minimum(np.minimum(np.asarray(view.vsmax, dtype=np.float64), p.vs_max_mps), (p.alt_max_m - alt) / t)
        return np.minimum(lo, 0.0), np.maximum(hi, 0.0)

    def _directed(self, sim: KinematicState, slots: np.ndarray,
                  horizon_s: float) -> tuple[TrafficSnapshot, np.ndarray, np.ndarray]:
        """Directed candidate pairs (ownship in ``slots``) for any direction the ownship may take."""
        p = self.daa.params
        return isotropic_pairs(sim, slots, horizon_s, max(p.dmod_m, p.recovery_m))

    # ----------------------------------------------------------------- bands
    def bands(self, sim: KinematicState, axis: str, slots: np.ndarray) -> AxisBands:
        """Conflict bands of ``axis`` (``hdg`` or ``vs``) for the aircraft in ``slots``."""
        p = self.daa.params
        slots = np.asarray(slots, dtype=np.int64)
        n = sim.view.n
        if axis == HDG:
            vmin, vmax = np.zeros(n), np.full(n, 360.0)
        else:
            vmin, vmax = self.vs_range(sim)
        if n < 2 or slots.size == 0:
            e = np.empty(0)
            return AxisBands(axis, np.empty(0, dtype=np.int64), e, e, vmin, vmax)
        s, own, intr = self._directed(sim, slots, p.lookahead_s)
        vol = (p.dmod_m, p.hmd_m, p.taumod_s, p.zthr_m, p.tcoa_s, p.lookahead_s)
        if axis == HDG:
            gs = np.hypot(s.u, s.v)
            owner, lo, hi = pair_hdg_bands(*s.frame, s.alt, s.u, s.v, s.w, gs, own, intr, p.hdg_step_deg, *vol)
        else:
            owner, lo, hi = pair_vs_bands(*s.frame, s.alt, s.u, s.v, s.w, own, intr, vmin, vmax, *vol)
        return AxisBands(axis, owner, lo, hi, vmin, vmax)

    # ----------------------------------------------------------- coordination
    def senses(self, sim: KinematicState, axis: str, slots: np.ndarray, urgent: np.ndarray) -> np.ndarray:
        """Per slot, the coordinated direction against intruder ``urgent`` (-1: none): RIGHT_UP or LEFT_DOWN."""
        s = geometry_of(sim)
        view = sim.view
        out = np.zeros(len(slots), dtype=np.int64)
        for k, (i, j) in enumerate(zip(np.asarray(slots).tolist(), np.asarray(urgent).tolist())):
            if j < 0:
                continue
            if axis == VS:
                dz = float(s.alt[i] - s.alt[j])
                out[k] = (RIGHT_UP if dz > 0 else LEFT_DOWN) if abs(dz) >= 1.0 else \
                    (RIGHT_UP if view.ids[i] < view.ids[j] else LEFT_DOWN)
                continue
            sx, sy = float(s.x[i] - s.x[j]), float(s.y[i] - s.y[j])
            vx, vy = float(s.u[i] - s.u[j]), float(s.v[i] - s.v[j])
            cross = sx * vy - sy * vx
            eps = 1.0 if abs(cross) <= 1e-6 * math.hypot(sx, sy) * max(math.hypot(vx, vy), 1e-9) else \
                math.copysign(1.0, cross)
            trk = math.radians(float(view.trk[i] if view.gs[i] > 0.1 else view.hdg[i]))
            ahead = -(sx * math.sin(trk) + sy * math.cos(trk))  # > 0: the intruder is ahead
            # A right turn changes s x v by s x dv with dv along (cos h, -sin h): sign of -(s . e).
            out[k] = RIGHT_UP if eps * (ahead if ahead != 0.0 else 1.0) > 0 else LEFT_DOWN
        return out

    # ------------------------------------------------------------ resolutions
    def resolve(self, sim: KinematicState, axis: str, slots: np.ndarray, bands: AxisBands,
                urgent: np.ndarray) -> list[AxisResolution]:
        """Per slot, the resolution on ``axis`` in the preferred direction (value NaN: saturated bands)."""
        p = self.daa.params
        view = sim.view
        senses = self.senses(sim, axis, slots, urgent)
        out: list[AxisResolution] = []
        for k, i in enumerate(np.asarray(slots, dtype=np.int64).tolist()):
            acid = view.ids[i]
            if axis == HDG:
                h0 = float(view.trk[i] if view.gs[i] > 0.1 else view.hdg[i])
                right, left = heading_directions(bands.of(i), h0, p.hdg_margin_deg, p.max_turn_deg)
                values = {RIGHT_UP: (h0 + right) % 360.0, LEFT_DOWN: (h0 - left) % 360.0}
                dev = {RIGHT_UP: right, LEFT_DOWN: left}
                persist = p.persist_hdg_deg
            else:
                v0 = float(view.vs[i])
                up, down = linear_directions(bands.of(i), float(bands.vmin[i]), float(bands.vmax[i]), v0,
                                             p.vs_margin_mps)
                values = {RIGHT_UP: up, LEFT_DOWN: down}
                dev = {RIGHT_UP: up - v0, LEFT_DOWN: v0 - down}
                persist = p.persist_vs_mps
            ok = [d for d in (RIGHT_UP, LEFT_DOWN) if not math.isnan(dev[d])]
            if not ok:
                out.append(AxisResolution(axis, math.nan, 0, False))
                continue
            prev = self.preferred.get((acid, axis))
            other = -prev if prev is not None else 0
            if prev in ok and not (other in ok and dev[other] < dev[prev] - persist):
                d = prev
            elif int(senses[k]) in ok:
                d = int(senses[k])
            else:
                d = min(ok, key=lambda x: (dev[x], -x))  # the closer; a tie turns right / climbs
            self.preferred[(acid, axis)] = d
            out.append(AxisResolution(axis, float(values[d]), d, False))
        return out

    def candidates(self, sim: KinematicState, axis: str, slot: int, values: np.ndarray) -> np.ndarray:
        """Ownship velocities (east, north, up [m/s]; rows of ``values``) flying each value of ``axis``."""
        view = sim.view
        u, v, w = float(view.gseast[slot]), float(view.gsnorth[slot]), float(view.vs[slot])
        out = np.empty((len(values), 3))
        if axis == HDG:
            gs = math.hypot(u, v)
            rad = np.radians(values)
            out[:, 0], out[:, 1], out[:, 2] = gs * np.sin(rad), gs * np.cos(rad), w
        else:
            out[:, 0], out[:, 1], out[:, 2] = u, v, values
        return out

    def check_velocities(self, sim: KinematicState, slots: np.ndarray, vel: np.ndarray,
                         recovery: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """For candidate velocities ``vel`` (slots x candidates x 3) of each ownship, against every intruder:
        the earliest loss of well clear and the time well clear is regained [s from now] (the recovery
        volume when ``recovery``); ``inf`` / 0 without a loss."""
        p = self.daa.params
        slots = np.asarray(slots, dtype=np.int64)
        nc = vel.shape[1]
        first = np.full((slots.size, nc), np.inf)
        regain = np.zeros((slots.size, nc))
        if slots.size == 0 or sim.view.n < 2:
            return first, regain
        horizon = p.recovery_lookahead_s if recovery else p.lookahead_s
        s, own, intr = self._directed(sim, slots, horizon)
        if own.size == 0:
            return first, regain
        row_of = np.full(sim.view.n, -1, dtype=np.int64)
        row_of[slots] = np.arange(slots.size)
        row = row_of[own]
        vol = (p.recovery_m, p.recovery_m, 0.0, p.recovery_zthr_m, 0.0) if recovery else \
            (p.dmod_m, p.hmd_m, p.taumod_s, p.zthr_m, p.tcoa_s)
        t_in, t_out = velocity_intervals(*s.frame, s.alt, s.u, s.v, s.w, own, intr, row,
                                         np.ascontiguousarray(vel[:, :, 0]), np.ascontiguousarray(vel[:, :, 1]),
                                         np.ascontiguousarray(vel[:, :, 2]), *vol)
        within = t_in <= horizon
        np.minimum.at(first, row, np.where(within, t_in, np.inf))
        np.maximum.at(regain, row, np.where(within, t_out, 0.0))
        return first, regain

    def recovery(self, sim: KinematicState, axis: str, slot: int, sense: int = 0) -> AxisResolution:
        """DAIDALUS's recovery value of ``axis`` for an aircraft whose every value loses well clear.

        Values on the coordinated side ``sense`` (:meth:`senses`; 0: either) come first, so that
        the two aircraft of a pair recover apart rather than both the same way.
        """
        p = self.daa.params
        view = sim.view
        if axis == HDG:
            x0 = float(view.trk[slot] if view.gs[slot] > 0.1 else view.hdg[slot])
            turn = np.arange(-p.max_turn_deg, p.max_turn_deg + 1e-9, p.hdg_step_deg)
            grid = (x0 + turn) % 360.0
        else:
            x0 = float(view.vs[slot])
            lo, hi = self.vs_range(sim)
            grid = np.arange(float(lo[slot]), float(hi[slot]) + 1e-9, p.vs_step_mps)
            turn = grid - x0
        vel = self.candidates(sim, axis, slot, grid)[None]
        rec_first, _ = self.check_velocities(sim, np.array([slot]), vel, recovery=True)
        _, regain = self.check_velocities(sim, np.array([slot]), vel)
        ok = np.flatnonzero(rec_first[0] > p.recovery_lookahead_s)
        if ok.size == 0:
            return AxisResolution(axis, math.nan, 0, True)
        sided = ok[turn[ok] * sense > 0] if sense else ok
        ok = sided if sided.size else ok
        best = ok[np.lexsort((np.abs(turn[ok]), regain[0, ok]))[0]]
        return AxisResolution(axis, float(grid[best]), int(np.sign(turn[best])), True)
