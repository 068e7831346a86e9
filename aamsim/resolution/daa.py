"""Detect and avoid: DO-365 / DAIDALUS alerting and ground-speed resolutions for every aircraft.

:class:`DetectAndAvoid` reads the traffic through a read-only kinematic state
(:class:`aamsim.resolution.state.KinematicState`: the simulation in process, or a
traffic snapshot of :data:`aamsim.resolution.state.DAA_FIELDS`) and the conflict
package's pair search, and answers three questions for any set of
aircraft:

* **alerts** (:meth:`DetectAndAvoid.alerts`): per aircraft, the highest alert
  level over its intruders (0 none, 1 preventive, 2 corrective, 3 warning) and
  the time to loss of well clear; a level is raised when its volume is lost
  within its alerting time (DAIDALUS's alerter, DO-365's three levels);
* **bands** (:meth:`DetectAndAvoid.gs_bands`): the ground speeds along the
  current track that lose well clear within the look-ahead;
* **resolutions** (:meth:`DetectAndAvoid.resolutions`): the conflict-free
  ground speed of the envelope closest to the current one, and the calibrated
  airspeed that flies it. When every speed conflicts (saturated bands), the
  recovery speed: as DAIDALUS's recovery bands, the speed that stays clear of
  the recovery volume (the NMAC distances) and regains well clear soonest;
  when none avoids even the recovery volume, no resolution (NaN).

The service (:mod:`aamsim.resolution.service`, stack command ``RESO DAA``) and
the ``daa`` baseline policy of the tactical use cases both use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from aamsim.aero import cas2tas, tas2cas
from aamsim.conflicts.axis_bands import velocity_intervals
from aamsim.conflicts.bands import pair_exit_times, pair_gs_bands
from aamsim.conflicts.service import TrafficSnapshot, search_pairs
from aamsim.conflicts.wellclear import pair_alerts
from aamsim.resolution.state import KinematicState, geometry_of
from aamsim.units import FPM, FT, KTS

NONE, PREVENTIVE, CORRECTIVE, WARNING = 0, 1, 2, 3
LEVEL_NAMES = ("none", "preventive", "corrective", "warning")
# Resolution axes (stack names HDG, VS, GS): track, vertical speed, ground speed.
RESOLUTION_AXES = ("hdg", "vs", "gs")


@dataclass
class DAAParams:
    """Thresholds of the detect-and-avoid logic (SI units; docs/daa.md explains the defaults).

    The horizontal thresholds are the AAM-Gym paper's loss of well clear (450 m)
    and the recovery volume its NMAC (150 m); the times, the vertical thresholds and
    the three alert levels are DO-365 Phase I's (ZTHR 450 ft, 700 ft for the
    preventive level; alerting times 55, 55 and 25 s; look-ahead 75 s).
    """

    dmod_m: float = 450.0  # DMOD: horizontal distance threshold
    hmd_m: float = 450.0  # HMD: horizontal miss-distance threshold
    taumod_s: float = 35.0  # TAUMOD: modified-tau threshold
    zthr_m: float = 450.0 * FT  # ZTHR: vertical threshold (corrective and warning volumes)
    tcoa_s: float = 0.0  # TCOA: time-to-co-altitude threshold
    preventive_zthr_m: float = 700.0 * FT  # ZTHR of the preventive volume
    preventive_s: float = 55.0  # alerting times [s]: preventive, corrective, warning
    corrective_s: float = 55.0
    warning_s: float = 25.0
    lookahead_s: float = 75.0  # bands: well clear over this time
    recovery_m: float = 150.0  # recovery volume when every speed loses well clear: DMOD = HMD (NMAC) ...
    recovery_zthr_m: float = 150.0  # ... and ZTHR; TAUMOD 0
    recovery_lookahead_s: float = 300.0  # recovery speeds stay clear of the recovery volume this long
    speed_min_kts: float = 0.0  # resolution speeds [CAS kt], within the aircraft's envelope
    speed_max_kts: float = 150.0
    margin_mps: float = 1.0  # a resolution lies this far inside its conflict-free band (ground speed)
    resolve_level: int = CORRECTIVE  # the alert level from which a resolution is issued
    interval_s: float = 1.0  # the service's cycle (DAIDALUS runs at 1 Hz)
    # An advisory is released only after the aircraft has been clear of conflict this long without a break.
    # DAIDALUS's DO-365B configurations hold their alerts 5 s (hysteresis_time); held advisories cost delay
    # for little safety here (docs/daa.md: on nyc_day 5 s gave 2.1 % fewer LoWC and 22 s more delay).
    hysteresis_s: float = 0.0
    # The axes RESO DAA resolves on, in order of preference: the first with a conflict-free value
    # flies it. Default: the guidance of DAIDALUS's DO-365 configurations (track, vertical speed,
    # horizontal speed; docs/daa.md).
    resolution_axes: tuple[str, ...] = RESOLUTION_AXES
    hdg_step_deg: float = 1.0  # heading bands: sampling step (DAIDALUS's step_hdir)
    hdg_margin_deg: float = 5.0  # a heading resolution lies this far inside its band (bands assume instant turns)
    max_turn_deg: float = 180.0  # turn limit each way (DAIDALUS's DO-365 left_hdir / right_hdir)
    vs_max_mps: float = 1000.0 * FPM  # vertical-speed resolutions within +-this (and the envelope)
    vs_margin_mps: float = 0.5  # a vertical-speed resolution lies this far inside its band
    vs_step_mps: float = 0.25  # vertical-speed grid of the recovery search
    alt_min_m: float = 100.0 * FT  # no vertical resolution crosses this floor (DAIDALUS's min_alt) ...
    alt_max_m: float = 3000.0 * FT  # ... or this ceiling within the look-ahead
    persist_hdg_deg: float = 15.0  # preferred direction kept unless the other is closer by this (DAIDALUS)
    persist_vs_mps: float = 250.0 * FPM

    def __post_init__(self) -> None:
        self.resolution_axes = check_axes(self.resolution_axes)
        for f in fields(self):
            if f.name == "resolution_axes":
                continue
            value = getattr(self, f.name)
            if not math.isfinite(value) or value < 0:
                raise ValueError(f"DAA {f.name} must be a finite number >= 0, not {value!r}")
        for name in ("dmod_m", "lookahead_s", "interval_s", "hdg_step_deg", "vs_step_mps"):
            if getattr(self, name) <= 0:  # a zero step divided by zero inside the bands, mid-run
                raise ValueError(f"DAA {name} must be positive, not {getattr(self, name)!r}")
        if self.speed_min_kts > self.speed_max_kts:
            raise ValueError("DAA speed_min_kts is above speed_max_kts")
        if int(self.resolve_level) != self.resolve_level or not PREVENTIVE <= self.resolve_level <= WARNING:
            raise ValueError("DAA resolve_level must be 1 (preventive), 2 (corrective) or 3 (warning)")

        if self.alt_min_m >= self.alt_max_m:
            raise ValueError("DAA alt_min_m must be below alt_max_m")

    def volumes(self) -> np.ndarray:
        """Rows DMOD, HMD, TAUMOD, ZTHR, TCOA of the preventive, corrective and warning volumes."""
        row = [self.dmod_m, self.hmd_m, self.taumod_s, self.zthr_m, self.tcoa_s]
        preventive = [self.dmod_m, self.hmd_m, self.taumod_s, self.preventive_zthr_m, self.tcoa_s]
        return np.array([preventive, row, row], dtype=np.float64)

    def alerting_times(self) -> np.ndarray:
        return np.array([self.preventive_s, self.corrective_s, self.warning_s], dtype=np.float64)

    def reach_m(self, vmax_mps: float) -> float:
        """Largest horizontal distance at which a pair with relative speed up to ``2 vmax`` can violate."""
        return max(self.dmod_m, self.recovery_m) + 2.0 * vmax_mps * self.taumod_s + 1.0


PARAM_NAMES = tuple(f.name for f in fields(DAAParams))


def isotropic_pairs(sim: KinematicState, slots: np.ndarray, horizon_s: float,
                    radius_m: float) -> tuple[TrafficSnapshot, np.ndarray, np.ndarray]:
    """The snapshot and directed candidate pairs (ownship in ``slots``, intruder) that can come within
    ``radius_m`` over ``horizon_s`` whatever direction and speed (up to the fastest envelope) either takes."""
    s = geometry_of(sim)
    n = len(s.ids)
    speed = np.hypot(np.hypot(s.u, s.v), s.w)
    reach = float(max(speed.max(initial=0.0), float(np.max(sim.view.vmax, initial=0.0))))
    still = TrafficSnapshot(s.ids, s.lat, s.lon, s.alt, np.zeros(n), np.zeros(n), s.w, s.x, s.y, s.frame_err,
                            s.frame)
    pi, pj = search_pairs(still, np.zeros(n), np.zeros(n), radius_m + 2.0 * reach * horizon_s + 1.0)
    wanted = np.zeros(n, dtype=bool)
    wanted[np.asarray(slots, dtype=np.int64)] = True
    own = np.concatenate([pi[wanted[pi]], pj[wanted[pj]]])
    intr = np.concatenate([pj[wanted[pi]], pi[wanted[pj]]])
    return s, own, intr


def check_axes(axes: Any) -> tuple[str, ...]:
    """Resolution axes as lower-case names; an unknown or repeated axis is an error naming it."""
    names = (axes,) if isinstance(axes, str) else tuple(axes)
    out: list[str] = []
    for a in names:
        key = str(a).lower()
        if key not in RESOLUTION_AXES:
            known = ", ".join(x.upper() for x in RESOLUTION_AXES)
            raise ValueError(f"unknown DAA resolution axis {a!r}; known: {known}")
        if key in out:
            raise ValueError(f"DAA resolution axis {str(a).upper()} is given twice")
        out.append(key)
    if not out:
        raise ValueError("DAA needs at least one resolution axis (HDG, VS, GS)")
    return tuple(out)


@dataclass(frozen=True)
class Alerts:
    """Alert levels now (slots of the view at assessment time)."""

    ids: tuple[str, ...]
    level: np.ndarray  # per slot, 0..3
    time_to_lowc_s: np.ndarray  # per slot, under the corrective volume (inf: well clear over the look-ahead)
    pi: np.ndarray  # candidate pairs (slots i < j) ...
    pj: np.ndarray
    pair_level: np.ndarray  # ... and their alert levels
    pair_t_in: np.ndarray  # ... and their times to loss of well clear (corrective volume; inf: none)


@dataclass(frozen=True)
class SpeedBands:
    """Ground-speed conflict bands of some aircraft: rows (slot, lo, hi) [m/s], disjoint and sorted per slot."""

    slot: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    gmin: np.ndarray  # per slot of the traffic: the resolution range [m/s of ground speed]
    gmax: np.ndarray

    def of(self, slot: int) -> list[tuple[float, float]]:
        sel = self.slot == slot
        return list(zip(self.lo[sel].tolist(), self.hi[sel].tolist()))

    def free_of(self, slot: int) -> list[tuple[float, float]]:
        """The conflict-free bands of one aircraft within its range."""
        out: list[tuple[float, float]] = []
        start = float(self.gmin[slot])
        for lo, hi in self.of(slot):
            if lo > start:
                out.append((start, lo))
            start = max(start, hi)
        if start < self.gmax[slot]:
            out.append((start, float(self.gmax[slot])))
        return out

    def conflicts(self, slot: int, gs: float) -> bool:
        """Whether ground speed ``gs`` lies in a conflict band of ``slot``."""
        return any(lo <= gs <= hi for lo, hi in self.of(slot))


def closest_free(free: list[tuple[float, float]], conflict_edges: set[float], g: float, margin: float) -> float:
    """The point of the conflict-free bands closest to ``g``, kept ``margin`` inside edges that border a conflict."""
    best, best_d = math.nan, math.inf
    for lo, hi in free:
        a = lo + (margin if lo in conflict_edges else 0.0)
        b = hi - (margin if hi in conflict_edges else 0.0)
        x = min(max(g, a), b) if a <= b else 0.5 * (lo + hi)
        if abs(x - g) < best_d:
            best, best_d = x, abs(x - g)
    return best


class DetectAndAvoid:
    """The DAA logic on a simulation (see the module docstring)."""

    def __init__(self, params: DAAParams | None = None):
        self.params = params or DAAParams()

    def set(self, **changes: Any) -> None:
        """Change parameters (checked together; unknown names are an error)."""
        unknown = sorted(set(changes) - set(PARAM_NAMES))
        if unknown:
            raise KeyError(f"unknown DAA parameter(s) {', '.join(unknown)}; known: {', '.join(PARAM_NAMES)}")
        values = {f: getattr(self.params, f) for f in PARAM_NAMES}
        values.update(changes)
        self.params = DAAParams(**values)

    # ---------------------------------------------------------------- state
    def _ranges(self, sim: KinematicState) -> tuple[np.ndarray, np.ndarray]:
        """Per aircraft, the ground-speed range of resolutions: the envelope cut to the speed limits."""
        view, p = sim.view, self.params
        alt = np.asarray(view.alt, dtype=np.float64)
        lo_cas, hi_cas = p.speed_min_kts * KTS, p.speed_max_kts * KTS
        # Rotorcraft limit TAS, fixed wing CAS (aamsim.traffic.performance).
        env_lo = np.where(view.rotor, view.vmin, cas2tas(np.asarray(view.vmin, dtype=np.float64), alt))
        env_hi = np.where(view.rotor, view.vmax, cas2tas(np.asarray(view.vmax, dtype=np.float64), alt))
        tas_lo = np.maximum(np.maximum(env_lo, cas2tas(np.full_like(alt, lo_cas), alt)), 0.0)
        tas_hi = np.minimum(env_hi, cas2tas(np.full_like(alt, hi_cas), alt))
        wind = view.gs - view.tas  # along-track wind, kept while the speed changes
        gmin = np.maximum(tas_lo + wind, 0.0)
        gmax = np.maximum(tas_hi + wind, gmin)
        return gmin, gmax

    def _search(self, sim: KinematicState, s: TrafficSnapshot, gmax: np.ndarray,
                horizon_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Candidate pairs over ``horizon_s`` at any resolution speed, and the tracks' unit vectors."""
        n = len(s.ids)
        trk = np.radians(np.where(sim.view.gs > 0.1, sim.view.trk, sim.view.hdg))
        ex, ey = np.sin(trk), np.cos(trk)
        reach = np.maximum(gmax, np.hypot(s.u, s.v))
        swept = TrafficSnapshot(s.ids, s.lat, s.lon, s.alt, reach * ex, reach * ey, s.w, s.x, s.y, s.frame_err,
                                s.frame)
        radius = self.params.reach_m(float(reach.max(initial=0.0)))
        pi, pj = search_pairs(swept, np.zeros(n), np.full(n, horizon_s), radius)
        return pi, pj, ex, ey

    def alerts(self, sim: KinematicState) -> Alerts:
        """Alert levels of every aircraft now."""
        p = self.params
        s = geometry_of(sim)
        n = len(s.ids)
        level = np.zeros(n, dtype=np.int64)
        tlowc = np.full(n, np.inf)
        empty = np.empty(0, dtype=np.int64)
        if n < 2:
            return Alerts(tuple(s.ids), level, tlowc, empty, empty, empty, np.empty(0))
        horizon = max(p.lookahead_s, p.preventive_s, p.corrective_s, p.warning_s)
        speed = np.hypot(s.u, s.v)
        pi, pj = search_pairs(s, np.zeros(n), np.full(n, horizon), p.reach_m(float(speed.max(initial=0.0))))
        plevel, t_in = pair_alerts(*s.frame, s.alt, s.u, s.v, s.w, pi, pj, p.volumes(), p.alerting_times(), horizon)
        np.maximum.at(level, pi, plevel)
        np.maximum.at(level, pj, plevel)
        np.minimum.at(tlowc, pi, t_in[:, CORRECTIVE - 1])
        np.minimum.at(tlowc, pj, t_in[:, CORRECTIVE - 1])
        return Alerts(tuple(s.ids), level, tlowc, pi, pj, plevel, t_in[:, CORRECTIVE - 1].copy())

    def _directed(self, sim: KinematicState, slots: np.ndarray,
                  horizon_s: float | None = None) -> tuple[TrafficSnapshot, np.ndarray, np.ndarray, np.ndarray,
                                                           np.ndarray]:
        """The snapshot, directed candidate pairs (ownship in ``slots``, intruder) over ``horizon_s`` (default:
        the look-ahead) and the tracks' unit vectors."""
        s = geometry_of(sim)
        _gmin, gmax = self._ranges(sim)
        pi, pj, ex, ey = self._search(sim, s, gmax, horizon_s or self.params.lookahead_s)
        wanted = np.zeros(len(s.ids), dtype=bool)
        wanted[slots] = True
        own = np.concatenate([pi[wanted[pi]], pj[wanted[pj]]])
        intr = np.concatenate([pj[wanted[pi]], pi[wanted[pj]]])
        return s, own, intr, ex, ey

    def gs_bands(self, sim: KinematicState, slots: np.ndarray, recovery: bool = False) -> SpeedBands:
        """Ground-speed conflict bands of the aircraft in ``slots`` (the recovery volume when ``recovery``)."""
        p = self.params
        gmin, gmax = self._ranges(sim)
        slots = np.asarray(slots, dtype=np.int64)
        if sim.view.n < 2 or slots.size == 0:
            empty = np.empty(0)
            return SpeedBands(np.empty(0, dtype=np.int64), empty, empty, gmin, gmax)
        horizon = p.recovery_lookahead_s if recovery else p.lookahead_s
        s, own, intr, ex, ey = self._directed(sim, slots, horizon)
        owner, lo, hi = pair_gs_bands(*s.frame, s.alt, s.u, s.v, s.w, ex, ey, own, intr, gmin, gmax,
                                      *self._volume(recovery), horizon)
        return SpeedBands(owner, lo, hi, gmin, gmax)

    def _volume(self, recovery: bool) -> tuple[float, float, float, float, float]:
        p = self.params
        if recovery:
            return p.recovery_m, p.recovery_m, 0.0, p.recovery_zthr_m, 0.0
        return p.dmod_m, p.hmd_m, p.taumod_s, p.zthr_m, p.tcoa_s

    def recovery_speeds(self, sim: KinematicState, slots: np.ndarray, step_mps: float = 0.5) -> np.ndarray:
        """For aircraft whose every speed loses well clear: the speed that regains it soonest [m/s of GS].

        As DAIDALUS's recovery bands: among the speeds (on a ``step_mps`` grid) that stay
        clear of the recovery volume (the NMAC distances) for ``recovery_lookahead_s``, the one
        whose losses of well clear end first; ties go to the speed closest to the
        current one. NaN where every speed enters the recovery volume.
        """
        slots = np.asarray(slots, dtype=np.int64)
        out = np.full(slots.size, np.nan)
        rec = self.gs_bands(sim, slots, recovery=True)
        s, own, intr, ex, ey = self._directed(sim, slots)
        top = float(rec.gmax[slots].max(initial=0.0))
        grid = np.arange(0.0, top + step_mps, step_mps)
        exits = pair_exit_times(*s.frame, s.alt, s.u, s.v, s.w, ex, ey, own, intr, grid, *self._volume(False),
                                self.params.lookahead_s)
        gs_now = sim.view.gs
        for k, i in enumerate(slots.tolist()):
            ok = (grid >= rec.gmin[i]) & (grid <= rec.gmax[i])
            ok &= ~np.array([rec.conflicts(i, float(g)) for g in grid])
            if not ok.any():
                continue
            mine = own == i
            last = exits[mine].max(axis=0) if mine.any() else np.zeros(grid.size)
            cand = np.flatnonzero(ok)
            best = cand[np.lexsort((np.abs(grid[cand] - gs_now[i]), last[cand]))[0]]
            out[k] = grid[best]
        return out

    # --------------------------------------------------------- coordination
    def sides(self, sim: KinematicState, alerts: Alerts, slots: np.ndarray) -> np.ndarray:
        """Per slot, the side of its speed resolution against its most urgent intruder.

        +1: it passes first (keeps its speed, or gains speed if that is needed), -1: it
        yields (slows), 0: no intruder ahead in time (either side). Speed-only resolutions of two aircraft that each assume the other
        flies on can both slow down and stall each other (a symmetric crossing ends in
        two hovering aircraft); this implicit coordination, antisymmetric within the
        pair, makes them move apart along their tracks. The aircraft that passes first
        is the one ahead at the closest point of approach, measured along both tracks
        (``s_c . (e_own + e_intruder)``, ``s_c`` the ownship's position relative to the
        intruder there); a tie goes to the callsign that sorts first.
        """
        view = sim.view
        out = np.zeros(len(slots), dtype=np.int64)
        if alerts.pi.size == 0:
            return out
        s = geometry_of(sim)
        trk = np.radians(np.where(view.gs > 0.1, view.trk, view.hdg))
        ex, ey = np.sin(trk), np.cos(trk)
        for k, i in enumerate(np.asarray(slots, dtype=np.int64).tolist()):
            mine = np.flatnonzero((alerts.pi == i) | (alerts.pj == i))
            if mine.size == 0:
                continue
            q = mine[int(np.argmin(alerts.pair_t_in[mine]))]
            if not math.isfinite(alerts.pair_t_in[q]):
                continue
            j = int(alerts.pj[q] if alerts.pi[q] == i else alerts.pi[q])
            sx, sy = s.x[i] - s.x[j], s.y[i] - s.y[j]
            vx, vy = s.u[i] - s.u[j], s.v[i] - s.v[j]
            v2 = vx * vx + vy * vy
            tc = max(0.0, -(sx * vx + sy * vy) / v2) if v2 > 1e-9 else 0.0
            cx, cy = sx + tc * vx, sy + tc * vy
            lead = cx * (ex[i] + ex[j]) + cy * (ey[i] + ey[j])
            if abs(lead) < 1.0:
                lead = 1.0 if view.ids[i] < view.ids[j] else -1.0
            out[k] = 1 if lead > 0 else -1
        return out

    def resume_order(self, sim: KinematicState, slots: np.ndarray, velocities: np.ndarray | None = None,
                     resuming: np.ndarray | None = None, resuming_velocities: np.ndarray | None = None) -> np.ndarray:
        """Which of the aircraft in ``slots``, all ready to resume their own trajectory, resume now.

        Two aircraft that held each other up would both resume at once and meet again
        (each checked its own way against the other as it flies now). Of two ready
        aircraft whose resumed trajectories (``velocities``: east, north, up [m/s] per
        slot; default: as they fly now) lose well clear of each other within the
        look-ahead, only the callsign that sorts first resumes this cycle. Ready aircraft
        that stay well clear of each other both resume: one that cannot resume yet does
        not hold up every other aircraft near it (on nyc_train_100 it held departures
        hovering for minutes, docs/daa.md).

        ``resuming``: aircraft already released and still turning back (with
        ``resuming_velocities``, the way they turn to): they went first, so a ready aircraft
        whose resumed trajectory loses well clear of theirs waits (seen as they fly now,
        mid-turn, they would not hold it up).
        """
        slots = np.asarray(slots, dtype=np.int64)
        allowed = np.ones(slots.size, dtype=bool)
        went = np.zeros(0, dtype=np.int64) if resuming is None else np.asarray(resuming, dtype=np.int64)
        if slots.size + went.size < 2 or slots.size == 0:
            return allowed
        p = self.params
        both = np.concatenate([slots, went])
        s, own, intr = isotropic_pairs(sim, both, p.lookahead_s, max(p.dmod_m, p.recovery_m))
        ids = sim.view.ids
        ready = np.zeros(len(s.ids), dtype=bool)
        ready[slots] = True
        gone = np.zeros(len(s.ids), dtype=bool)
        gone[went] = True
        first = np.array([gone[j] or ids[j] < ids[o] for o, j in zip(own.tolist(), intr.tolist())], dtype=bool)
        sel = ready[own] & (ready[intr] | gone[intr]) & first if own.size else np.zeros(0, dtype=bool)
        own, intr = own[sel], intr[sel]
        if own.size == 0:
            return allowed
        u, v, w = s.u.copy(), s.v.copy(), s.w.copy()
        if velocities is not None:
            vel = np.asarray(velocities, dtype=np.float64)
            u[slots], v[slots], w[slots] = vel[:, 0], vel[:, 1], vel[:, 2]
        if went.size and resuming_velocities is not None:
            vel = np.asarray(resuming_velocities, dtype=np.float64)
            u[went], v[went], w[went] = vel[:, 0], vel[:, 1], vel[:, 2]
        order = np.sort(slots)  # candidate rows: the ready aircraft by slot
        row = np.searchsorted(order, own)
        cu, cv, cw = (x[order][:, None].copy() for x in (u, v, w))
        t_in, _ = velocity_intervals(*s.frame, s.alt, u, v, w, own, intr, row, cu, cv, cw, p.dmod_m, p.hmd_m,
                                     p.taumod_s, p.zthr_m, p.tcoa_s)
        deferred = set(own[t_in[:, 0] <= p.lookahead_s].tolist())
        return np.array([i not in deferred for i in slots.tolist()], dtype=bool)

    # ----------------------------------------------------------- resolutions
    def resolutions(self, sim: KinematicState, slots: np.ndarray, bands: SpeedBands | None = None,
                    sides: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Per slot in ``slots``: the resolution ground speed [m/s] and the CAS that flies it [m/s].

        The conflict-free ground speed closest to the current one (the current one when
        it is conflict-free), on the side given by ``sides`` (:meth:`sides`; none: either):
        an aircraft that passes first and has no faster conflict-free speed keeps its
        speed (NaN: no advisory), one that yields and has no slower one takes the closest
        on either side. Saturated bands: the recovery volume's bands. NaN when nothing
        avoids even the recovery volume.
        """
        slots = np.asarray(slots, dtype=np.int64)
        bands = bands if bands is not None else self.gs_bands(sim, slots)
        sides = np.zeros(slots.size, dtype=np.int64) if sides is None else np.asarray(sides)
        view = sim.view
        target = np.full(slots.size, np.nan)
        saturated: list[int] = []
        for k, i in enumerate(slots.tolist()):
            if not bands.free_of(i):
                saturated.append(k)
                continue
            target[k] = self.pick(bands, i, float(view.gs[i]), int(sides[k]))
        if saturated:
            target[saturated] = self.recovery_speeds(sim, slots[saturated])
        return target, self.cas_for(sim, slots, target)

    def pick(self, bands: SpeedBands, slot: int, gs: float, side: int) -> float:
        """The conflict-free ground speed closest to ``gs`` on ``side`` (NaN: passes first at its speed)."""
        conflict = bands.of(slot)
        edges = {x for band in conflict for x in band}
        free = bands.free_of(slot)
        if side != 0:
            part = [(max(lo, gs), hi) if side > 0 else (lo, min(hi, gs)) for lo, hi in free]
            part = [(lo, hi) for lo, hi in part if lo <= hi]
            if part:
                return closest_free(part, edges, gs, self.params.margin_mps)
            if side > 0:
                return math.nan  # passes first and cannot go faster: keeps its speed
        return closest_free(free, edges, gs, self.params.margin_mps)

    @staticmethod
    def cas_for(sim: KinematicState, slots: np.ndarray, gs: np.ndarray) -> np.ndarray:
        """The CAS [m/s] that flies ground speed ``gs`` with the along-track wind of now."""
        view = sim.view
        tas = np.maximum(gs - (view.gs[slots] - view.tas[slots]), 0.0)
        known = np.isfinite(tas)
        cas = np.full(tas.shape, np.nan)
        cas[known] = tas2cas(tas[known], np.asarray(view.alt[slots], dtype=np.float64)[known])
        return cas

    @staticmethod
    def gs_for(sim: KinematicState, slots: np.ndarray, cas: np.ndarray) -> np.ndarray:
        """The ground speed [m/s] that CAS ``cas`` flies with the along-track wind of now."""
        view = sim.view
        tas = np.asarray(cas2tas(np.asarray(cas, dtype=np.float64), np.asarray(view.alt[slots], dtype=np.float64)))
        return np.asarray(tas + (view.gs[slots] - view.tas[slots]), dtype=np.float64)
