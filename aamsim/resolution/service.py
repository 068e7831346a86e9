"""The DAA alerting and resolution service, switched on by ``RESO DAA``.

Every ``interval_s`` (1 s) while ``RESO DAA`` is on, the service

1. computes every aircraft's alert level (:class:`~aamsim.resolution.daa.DetectAndAvoid`);
2. gives each aircraft at or above the resolution level (corrective by default)
   whose trajectory loses well clear an **advisory** on the first of the
   resolution axes (``DAA RESOAXES``; default heading, vertical speed, ground
   speed) that has a conflict-free value, in its preferred direction
   (:mod:`aamsim.resolution.axes`; ground speed: the pair's coordination of
   :meth:`DetectAndAvoid.sides`); when no axis has one, the first recovery
   value (DAIDALUS's recovery bands). A ground-speed advisory is a selected
   CAS (BlueSky's ``SPD``; the aircraft keeps its route); a heading or
   vertical-speed advisory is flown as a conflict resolution's commands
   (:meth:`~aamsim.api.SimulationAPI.command_resolution`, BlueSky's ASAS): the
   heading, or the vertical speed along the route's track, the rest as the
   autopilot has it. The aircraft's own speed, VNAV speed mode and route
   guidance are noted first;
3. holds each advisory while the aircraft is alerted or its own trajectory
   (route or noted track, own speed, towards its selected altitude) would
   still lose well clear, replacing it only when the held value itself comes
   to lose well clear (a new intruder, a manoeuvring one);
4. resumes once clear of conflict: no alert at the resolution level and the own
   trajectory conflict-free, the turn back to it included (every heading on the
   way, at the heading bands' step), for ``hysteresis_s`` without a break (0 s
   by default), or at once when the held advisory itself comes to lose well
   clear (of two nearby aircraft ready at once, one resumes first, and an
   aircraft still turning back counts as gone first:
   :meth:`DetectAndAvoid.resume_order`): the own speed and VNAV speed
   control, and the route (LNAV to the nearest waypoint) or the autopilot's track;
5. brings an aircraft a heading or vertical-speed advisory took off its route
   back to its destination (:class:`~aamsim.resolution.rejoin.RouteKeeper`):
   LNAV goes back on only when the aircraft can turn onto its last waypoint
   (straight on until then), and a route that ended (LNAV off at the last
   waypoint) before the aircraft came within 0.05 NM of that waypoint is flown
   again. Plain LNAV there can pass the destination a few hundred metres off
   and fly on for good (``RESO DAA`` on nyc_train_100, seed 1: 8 of 100
   flights never arrived).

Each advisory issued (a new or a replaced one) is counted in the flight's
advisories (the operational metric ``alert_rate_per_flight_hour``); the alerts
raised per level are counted in :attr:`DAAService.alert_counts`.
``RESO OFF`` releases every advisory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.aero import mach2cas
from aamsim.geo import degto180
from aamsim.hooks import sleep_while_unchanged
from aamsim.metrics import record_advisory
from aamsim.resolution.axes import GS, HDG, VS, AxisBands, AxisResolver
from aamsim.resolution.daa import LEVEL_NAMES, Alerts, DetectAndAvoid, SpeedBands
from aamsim.resolution.rejoin import ARRIVAL_M, RouteKeeper
from aamsim.units import Speed

if TYPE_CHECKING:
    from aamsim.simapi import SimulationCore

METHOD = "DAA"
ADVISORY_NAMES = {GS: "speed", HDG: "heading", VS: "vertical speed"}
_TIME_EPS = 1e-6  # sim times are sums of steps: 5 s of hold may read 4.9999999


@dataclass
class Advisory:
    """A resolution held by one aircraft (ground-speed fields NaN on the other axes)."""

    cas_mps: float  # the advised CAS (ground-speed axis)
    gs_mps: float  # the ground speed it was chosen for (ground-speed axis)
    resume: Speed  # the aircraft's own selected speed, resumed when clear
    resume_vnav_speed: bool
    since_s: float
    axis: str = GS  # the axis of the advisory now
    value: float = math.nan  # its value: ground speed [m/s], track [deg] or vertical speed [m/s]
    speed_held: bool = False  # a speed advisory was selected (the own speed is resumed when clear)
    asas: bool = False  # flies a resolution's commands (heading, vertical speed)
    resume_lnav: bool = False  # was on its route (LNAV): resumes it when clear
    resume_trk: float = math.nan  # its track when first advised, resumed without a route [deg]
    clear_since_s: float = math.nan  # sim time since which it has been clear of conflict without a break


def most_urgent(alerts: Alerts, slots: np.ndarray) -> np.ndarray:
    """Per slot, the intruder it loses well clear with first (-1: none)."""
    out = np.full(len(slots), -1, dtype=np.int64)
    for k, i in enumerate(np.asarray(slots, dtype=np.int64).tolist()):
        mine = np.flatnonzero((alerts.pi == i) | (alerts.pj == i))
        if mine.size == 0:
            continue
        q = mine[int(np.argmin(alerts.pair_t_in[mine]))]
        if math.isfinite(alerts.pair_t_in[q]):
            out[k] = int(alerts.pj[q] if alerts.pi[q] == i else alerts.pi[q])
    return out


@dataclass
class DAAService:
    """Per-simulation DAA alerting and resolutions (see the module docstring)."""

    daa: DetectAndAvoid = field(default_factory=DetectAndAvoid)
    advisories: dict[str, Advisory] = field(default_factory=dict)
    levels: dict[str, int] = field(default_factory=dict)  # alert level of each alerted aircraft at the last cycle
    alert_counts: dict[str, int] = field(default_factory=lambda: {n: 0 for n in LEVEL_NAMES[1:]})
    issued: int = 0  # advisories issued over the run
    issued_by_axis: dict[str, int] = field(default_factory=lambda: {GS: 0, HDG: 0, VS: 0})
    # The aircraft advised off their route, until they are back at their destination.
    keeper: RouteKeeper = field(default_factory=lambda: RouteKeeper(ARRIVAL_M))
    _raised: dict[str, int] = field(default_factory=dict)  # the level each aircraft was last counted at
    _turning_back: set[str] = field(default_factory=set)  # released from a heading advisory, still turning
    _axes: AxisResolver | None = None
    _hook: Any = None  # the cycle's post-step hook (it sleeps while idle)

    def attach(self, sim: SimulationCore) -> None:
        # After the conflict check (priority 10): both see the same state.
        self._hook = sim.hooks.post_step.add(self.update, interval_s=lambda: self.daa.params.interval_s, name="daa",
                                             priority=20)
        sim.hooks.deleted.add(self.on_deleted, name="daa.deleted")
        sim.hooks.reset.add(self.on_reset, name="daa.reset")
        self.keeper.attach(sim, name="daa.route_keeper")

    @property
    def axes(self) -> AxisResolver:
        if self._axes is None or self._axes.daa is not self.daa:
            self._axes = AxisResolver(self.daa)
        return self._axes

    @staticmethod
    def active(sim: SimulationCore) -> bool:
        return sim.settings.reso.upper() == METHOD

    def on_reset(self, sim: SimulationCore) -> None:
        self.advisories.clear()
        self.levels.clear()
        self._raised.clear()
        self._turning_back.clear()
        self.keeper.clear()
        self._axes = None

    def on_deleted(self, sim: SimulationCore, slot: int, record: object) -> None:
        acid = sim.view.ids[slot]
        self.advisories.pop(acid, None)
        self.levels.pop(acid, None)
        self._raised.pop(acid, None)
        self._turning_back.discard(acid)
        self.keeper.forget(acid)
        self.axes.forget(acid)

    # ---------------------------------------------------------------- cycle
    def _sleep(self, sim: SimulationCore) -> None:
        """Idle (RESO is not DAA, no advisory, nobody steered): sleep until one of these or the interval changes.

        Each cycle slept through would have found nothing to do; awake, each ended a batch of
        kernel steps.
        """
        sleep_while_unchanged(sim.hooks.post_step, self._hook, sim._clock,
                              lambda: (sim.settings.reso, bool(self.advisories), bool(self.keeper.steered)))

    def update(self, sim: SimulationCore) -> None:
        if self.keeper.steered:  # also after RESO OFF: the aircraft released then still go back to their route
            self.keeper.keep(sim, {acid for acid, adv in self.advisories.items() if adv.asas})
        if not self.active(sim):
            if self.advisories:
                self.release_all(sim)
            elif not self.keeper.steered:
                self._sleep(sim)
            return
        view = sim.view
        p = self.daa.params
        alerts = self.daa.alerts(sim)
        self._count_alerts(alerts.ids, alerts.level)
        alerted = alerts.level >= p.resolve_level
        held = np.array([a in self.advisories for a in alerts.ids], dtype=bool)
        # Replayed real traffic is an intruder only: it takes no advisory.
        slots = np.flatnonzero((alerted | held) & ~np.asarray(view.noncooperative, dtype=bool))
        if slots.size == 0:
            return
        losing = alerts.time_to_lowc_s <= p.lookahead_s  # the trajectory of now loses well clear
        speed_bands = self.daa.gs_bands(sim, slots)
        axis_bands: dict[str, AxisBands] = {}
        need: list[int] = []
        clear: list[int] = []  # clear of conflict, held or not
        due: list[bool] = []  # ... and their advisory is to be released now
        for i in slots.tolist():
            adv = self.advisories.get(view.ids[i])
            if adv is None:
                if losing[i]:
                    need.append(i)
                continue
            if not alerted[i] and self._own_way_clear(sim, i, adv, speed_bands):
                if math.isnan(adv.clear_since_s):
                    adv.clear_since_s = sim.simt
                # Held for the hysteresis time; released at once if the advisory itself comes to lose well
                # clear meanwhile (the aircraft's own way is the clear one then).
                clear.append(i)
                due.append(sim.simt - adv.clear_since_s >= p.hysteresis_s - _TIME_EPS
                           or self._held_conflicts(sim, i, adv, speed_bands, axis_bands))
                if not due[-1] and adv.asas and adv.axis == VS:
                    self._fly(sim, i, adv)
                continue
            adv.clear_since_s = math.nan
            if self._held_conflicts(sim, i, adv, speed_bands, axis_bands):
                need.append(i)
            elif adv.asas and adv.axis == VS:
                self._fly(sim, i, adv)  # the vertical resolution follows the route's track
        if any(due):
            # The order of resuming among every clear aircraft, held ones included: of a pair whose ways back
            # meet, the one that sorts second waits even while the first still holds its advisory. Otherwise
            # their holds ended a cycle apart and both turned back into each other (tests/data/daa_turns.scn).
            vel = np.array([self._resume_velocity(sim, i, self.advisories[view.ids[i]]) for i in clear])
            turning = self._still_turning_back(sim)
            go = self.daa.resume_order(sim, np.array(clear, dtype=np.int64), vel, turning,
                                       self._way_back(sim, turning)) & np.array(due)
            for i in np.array(clear)[go].tolist():
                self._release(sim, view.ids[i], self.advisories[view.ids[i]])
        if need:
            self._resolve(sim, alerts, np.array(need, dtype=np.int64), speed_bands)

    def _resume_velocity(self, sim: SimulationCore, i: int, adv: Advisory) -> tuple[float, float, float]:
        """What the aircraft flies once released (east, north, up [m/s]): its own speed, along its route or
        noted track (along its track of now after a speed advisory), towards its selected altitude."""
        gs = float(self.daa.gs_for(sim, np.array([i]), np.array([self._resume_cas(sim, i, adv)]))[0])
        # Straight on where the route cannot be turned onto yet (the keeper's resume).
        on_route = adv.asas and not (adv.resume_lnav and len(sim.view.route(i)) and not self.keeper.can_rejoin(sim, i))
        trk = math.radians(self._route_track(sim, i, adv) if on_route else float(sim.view.trk[i]))
        vs = self._own_vs(sim, i) if adv.asas else float(sim.view.vs[i])
        return gs * math.sin(trk), gs * math.cos(trk), vs

    def _still_turning_back(self, sim: SimulationCore) -> np.ndarray:
        """Slots of the aircraft released from a heading advisory that still turn back to their route."""
        view, step = sim.view, self.daa.params.hdg_step_deg
        slots = []
        for acid in sorted(self._turning_back):
            i = view.slot(acid)
            if view.lnav[i] and abs(degto180(float(view.qdr2wp[i]) - float(view.trk[i]))) > step:
                slots.append(i)
            else:
                self._turning_back.discard(acid)
        return np.array(slots, dtype=np.int64)

    @staticmethod
    def _way_back(sim: SimulationCore, slots: np.ndarray) -> np.ndarray:
        """East, north, up [m/s] of ``slots`` once turned back to their active waypoint."""
        view = sim.view
        trk = np.radians(np.asarray(view.qdr2wp, dtype=np.float64)[slots])
        gs = np.asarray(view.gs, dtype=np.float64)[slots]
        return np.stack([gs * np.sin(trk), gs * np.cos(trk), np.asarray(view.vs, dtype=np.float64)[slots]], axis=1)

    def _own_way_clear(self, sim: SimulationCore, i: int, adv: Advisory, speed_bands: SpeedBands) -> bool:
        """Whether the aircraft's own trajectory (what it flies once released) keeps well clear."""
        if not adv.asas:
            resume_gs = float(self.daa.gs_for(sim, np.array([i]), np.array([self._resume_cas(sim, i, adv)]))[0])
            return not speed_bands.conflicts(i, resume_gs)
        # The way back: every heading of the turn from the track of now to the resumed one, at the heading
        # bands' step, not the resumed heading alone. Tested on that alone, an aircraft turning back met the
        # intruder on the way and was advised again at the next cycle (nyc_train_100: 2,680 advisories,
        # 967 of the 1,722 releases followed by a new advisory one cycle later; with the turn, 354 and 8 of
        # 194).
        ve, vn, vu = self._resume_velocity(sim, i, adv)
        trk_now = float(sim.view.trk[i])
        turn = degto180(math.degrees(math.atan2(ve, vn)) - trk_now)  # the shorter way, as LNAV
        n = max(1, math.ceil(abs(turn) / self.daa.params.hdg_step_deg))
        hdg = np.radians(trk_now + turn * np.arange(1, n + 1) / n)
        gs = math.hypot(ve, vn)
        vel = np.stack([gs * np.sin(hdg), gs * np.cos(hdg), np.full(n, vu)], axis=1)[None]
        first, _ = self.axes.check_velocities(sim, np.array([i]), vel)
        return bool((first[0] > self.daa.params.lookahead_s).all())

    def _held_conflicts(self, sim: SimulationCore, i: int, adv: Advisory, speed_bands: SpeedBands,
                        axis_bands: dict[str, AxisBands]) -> bool:
        if adv.axis == GS:
            return speed_bands.conflicts(i, adv.gs_mps)
        if adv.axis not in axis_bands:
            held = np.array([sim.view.slot(a) for a, h in self.advisories.items() if h.axis == adv.axis],
                            dtype=np.int64)
            axis_bands[adv.axis] = self.axes.bands(sim, adv.axis, held)
        return axis_bands[adv.axis].conflicts(i, adv.value)

    def _resolve(self, sim: SimulationCore, alerts: Alerts, need: np.ndarray, speed_bands: SpeedBands) -> None:
        """Advise each aircraft of ``need`` on the first axis with a conflict-free value, else by recovery."""
        axes = self.daa.params.resolution_axes
        urgent = most_urgent(alerts, need)
        left = np.ones(need.size, dtype=bool)
        for axis in axes:
            rows = np.flatnonzero(left)
            if rows.size == 0:
                return
            idx = need[rows]
            if axis == GS:
                sides = self.daa.sides(sim, alerts, idx)
                for r, i, side in zip(rows.tolist(), idx.tolist(), sides.tolist()):
                    if speed_bands.free_of(i):
                        g = self.daa.pick(speed_bands, i, float(sim.view.gs[i]), int(side))
                        if not math.isnan(g):
                            self._advise(sim, i, GS, g)
                            left[r] = False
                continue
            bands = self.axes.bands(sim, axis, idx)
            for r, res in zip(rows.tolist(), self.axes.resolve(sim, axis, idx, bands, urgent[rows])):
                if not math.isnan(res.value):
                    self._advise(sim, int(need[r]), axis, res.value)
                    left[r] = False
        for r in np.flatnonzero(left).tolist():  # saturated on every axis: the recovery bands
            i = int(need[r])
            for axis in axes:
                if axis == GS:
                    value = float(self.daa.recovery_speeds(sim, np.array([i]))[0])
                else:
                    sense = int(self.axes.senses(sim, axis, np.array([i]), urgent[r:r + 1])[0])
                    value = self.axes.recovery(sim, axis, i, sense).value
                if not math.isnan(value):
                    self._advise(sim, i, axis, value)
                    break

    def _count_alerts(self, ids: tuple[str, ...], level: np.ndarray) -> None:
        """Count each alert when it is raised or rises to a higher level."""
        now = {ids[i]: int(level[i]) for i in np.flatnonzero(level > 0).tolist()}
        for acid, lv in now.items():
            if lv > self._raised.get(acid, 0):
                self.alert_counts[LEVEL_NAMES[lv]] += 1
        self._raised = now
        self.levels = now

    # ------------------------------------------------------------- advisories
    def _advise(self, sim: SimulationCore, slot: int, axis: str, value: float) -> None:
        view = sim.view
        acid = view.ids[slot]
        adv = self.advisories.get(acid)
        if adv is None:
            resume = Speed(float(view.selspd[slot]), bool(view.selspd_mach[slot]))
            adv = Advisory(math.nan, math.nan, resume, bool(view.vnav_speed[slot]), sim.simt,
                           resume_lnav=bool(view.lnav[slot]) and len(view.route(slot)) > 0,
                           resume_trk=float(view.trk[slot]))
            self.advisories[acid] = adv
        adv.axis, adv.value = axis, value
        self._turning_back.discard(acid)  # advised again: it no longer turns back
        if axis == GS:
            if adv.asas:  # back to the autopilot (and the route) before a speed is selected
                self._stop_following(sim, slot, adv)
            cas = float(self.daa.cas_for(sim, np.array([slot]), np.array([value]))[0])
            adv.cas_mps, adv.gs_mps, adv.speed_held = cas, value, True
            sim.select_speed(slot, cas)
        else:
            adv.cas_mps = adv.gs_mps = math.nan
            self._fly(sim, slot, adv)
        self.issued += 1
        self.issued_by_axis[axis] += 1
        record_advisory(sim, acid, ADVISORY_NAMES[axis])

    def _fly(self, sim: SimulationCore, slot: int, adv: Advisory) -> None:
        """Command a heading or vertical-speed resolution (the other variables as the autopilot has them)."""
        view, p = sim.view, self.daa.params
        cas = float(view.selspd[slot])
        if view.selspd_mach[slot]:
            cas = mach2cas(cas, float(view.alt[slot]))
        gs = float(self.daa.gs_for(sim, np.array([slot]), np.array([cas]))[0])
        alt = float(view.alt[slot])
        if adv.axis == HDG:
            trk, vs, alt_cmd = adv.value, abs(float(view.ap_vs[slot])), float(view.selalt[slot])
        else:
            trk, vs = self._route_track(sim, slot, adv), abs(adv.value)
            alt_cmd = min(max(alt + adv.value * p.lookahead_s, p.alt_min_m), p.alt_max_m) if vs > 0 else alt
        sim.command_resolution(slot, trk, gs, vs, alt_cmd)
        if not adv.asas:
            sim.follow_resolution(slot, True)
            adv.asas = True
            if adv.resume_lnav:
                self.keeper.steer(view.ids[slot])

    @staticmethod
    def _route_track(sim: SimulationCore, slot: int, adv: Advisory) -> float:
        """The track the aircraft flies on its own: towards its active waypoint, or its noted track."""
        view = sim.view
        return float(view.qdr2wp[slot]) if adv.resume_lnav and len(view.route(slot)) else adv.resume_trk

    @staticmethod
    def _own_vs(sim: SimulationCore, slot: int) -> float:
        """The vertical speed the autopilot flies towards the selected altitude [m/s]."""
        view = sim.view
        dz = float(view.selalt[slot]) - float(view.alt[slot])
        return math.copysign(abs(float(view.ap_vs[slot])), dz) if abs(dz) > 1.0 else 0.0

    @staticmethod
    def _resume_cas(sim: SimulationCore, slot: int, adv: Advisory) -> float:
        if adv.resume.is_mach:
            return mach2cas(adv.resume.value, float(sim.view.alt[slot]))
        return adv.resume.value

    def _stop_following(self, sim: SimulationCore, slot: int, adv: Advisory) -> None:
        sim.follow_resolution(slot, False)
        adv.asas = False
        if adv.resume_lnav and len(sim.view.route(slot)):
            self.keeper.resume(sim, slot, sim.view.ids[slot], adv.resume_trk)

    def _release(self, sim: SimulationCore, acid: str, adv: Advisory) -> None:
        del self.advisories[acid]
        self.axes.forget(acid)
        slot = sim.view.slot(acid)
        if adv.asas:
            self._stop_following(sim, slot, adv)
            self._turning_back.add(acid)
        if adv.speed_held:
            sim.select_speed(acid, adv.resume)
            if adv.resume_vnav_speed:
                sim.set_navigation(acid, vnav_speed=True)

    def release_all(self, sim: SimulationCore) -> None:
        """Resume every aircraft's own speed and route (``RESO OFF``)."""
        for acid, adv in list(self.advisories.items()):
            if acid in sim.view:
                self._release(sim, acid, adv)
        self.advisories.clear()

    def summary(self) -> dict[str, object]:
        """Counts for the run's summary."""
        return {"advisories_issued": self.issued,
                "advisories_by_axis": {ADVISORY_NAMES[a]: n for a, n in self.issued_by_axis.items()},
                "alerts": dict(self.alert_counts), "params": {k: v for k, v in vars(self.daa.params).items()}}
