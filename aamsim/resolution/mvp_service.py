"""BlueSky's conflict resolution cycle with Modified Voltage Potential, switched on by ``RESO MVP``.

At every conflict-detection cycle (``DT ASAS``, 1 s; right after the check of
:mod:`aamsim.conflicts.service`), while ``RESO MVP`` is on, as BlueSky 1.1.1's
``ConflictResolution.update``:

1. when BlueSky's state-based detection finds conflict pairs (each pair seen
   from both sides, as BlueSky lists them: :mod:`aamsim.resolution.mvp_detect`),
   MVP (:mod:`aamsim.resolution.mvp`) computes a track, ground speed, vertical speed and altitude for every
   aircraft from the pairs of the check, each aircraft resolving its own side
   of each pair. These commands hold until the next cycle that has conflicts;
2. every pair that has been in conflict stays "being resolved" until it is
   past its closest point of approach (position and velocity of the intruder
   relative to the ownship point apart), its aircraft are not within the
   protected radius of each other and they are not flying nearly parallel
   (tracks within 30 deg) inside the resolution zone (a "bouncing" conflict).
   An aircraft with a pair being resolved flies the resolution's commands
   (:meth:`~aamsim.api.SimulationAPI.follow_resolution`); when its last pair
   ends, or its intruder is deleted, it goes back to its autopilot and flies
   direct to the best waypoint of its route (BlueSky's ``findact``: the
   nearest one not behind the active one), LNAV on.

The kernel flies the commands through the aircraft's envelope, as BlueSky's
APorASAS and performance limits do for the autopilot's
(:func:`aamsim.traffic.kernel`). ``RESO OFF`` (or another method) hands every
aircraft back to its autopilot at once, without the direct-to, as selecting
BlueSky's base resolution class does.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.hooks import sleep_while_unchanged
from aamsim.metrics import record_advisory
from aamsim.resolution.mvp import MVPSettings, OwnState, PairGeometry, combine, commands, mvp_pairs
from aamsim.resolution.mvp_detect import DirectedConflicts, detect
from aamsim.units import R_EARTH  # also the radius of BlueSky's flat-earth pair formulas

if TYPE_CHECKING:
    from aamsim.simapi import SimulationCore

METHOD = "MVP"
_BOUNCING_DEG = 30.0  # nearly parallel tracks: a conflict that keeps starting and ending


@dataclass
class MVPService:
    """Per-simulation MVP resolution (see the module docstring)."""

    settings: MVPSettings = field(default_factory=MVPSettings)
    pairs: set[tuple[str, str]] = field(default_factory=set)  # (ownship, intruder) being resolved
    no_reso: set[str] = field(default_factory=set)  # NORESO: nobody avoids these
    reso_off: set[str] = field(default_factory=set)  # RESOOFF: these avoid nobody
    following: set[str] = field(default_factory=set)  # callsigns flying the resolution now
    resolutions: int = 0  # times an aircraft started following a resolution
    _hook: Any = None

    def attach(self, sim: SimulationCore) -> None:
        # BlueSky detects and resolves inside the step that reaches each multiple of DT ASAS,
        # before that step moves the aircraft: here, at the boundary one step earlier, so the
        # resolution flies from that step on (see _reschedule).
        self._hook = sim.hooks.post_step.add(self.update, interval_s=lambda: sim.settings.cd_interval_s,
                                             name="mvp", priority=15)
        sim.hooks.deleted.add(self.on_deleted, name="mvp.deleted")
        sim.hooks.reset.add(self.on_reset, name="mvp.reset")

    @staticmethod
    def active(sim: SimulationCore) -> bool:
        return sim.settings.reso.upper() == METHOD

    def on_reset(self, sim: SimulationCore) -> None:
        self.settings = MVPSettings()
        self.pairs.clear()
        self.no_reso.clear()
        self.reso_off.clear()
        self.following.clear()
        self.resolutions = 0

    def on_deleted(self, sim: SimulationCore, slot: int, record: object) -> None:
        # Its pairs stay: the next cycle ends them and sends its intruders back to their routes.
        acid = sim.view.ids[slot]
        self.no_reso.discard(acid)
        self.reso_off.discard(acid)
        self.following.discard(acid)

    def toggle(self, which: set[str], callsigns: list[str]) -> None:
        """NORESO / RESOOFF: each callsign is added, or removed when it is there (BlueSky toggles)."""
        for acid in callsigns:
            which.symmetric_difference_update({acid})

    # ---------------------------------------------------------------- cycle
    def _reschedule(self, sim: SimulationCore) -> bool:
        """Keep the hook one step before each multiple of the interval; True when now is such a time."""
        dt_us = sim._clock.dt_us
        interval_us = max(round(sim.settings.cd_interval_s * 1e6), 1)
        now = sim._clock.simt_us
        on_time = (now + dt_us) % interval_us == 0
        target = ((now + dt_us) // interval_us + 1) * interval_us - dt_us  # the next such boundary
        # The hook list adds one interval to the due time after this call returns.
        self._hook.next_due_us = target - interval_us
        return on_time

    def _sleep(self, sim: SimulationCore) -> None:
        """Idle (RESO is not MVP, nobody follows a resolution): sleep until RESO, DT ASAS or DT changes.

        Until then each cycle only keeps its phase, and its boundary one step before each second
        split the kernel's batches in two (1 + 19 steps a second while a corridor episode's reset
        flies the traffic up to its ego). Called in a cycle on time: the due times slept through
        are this one plus whole intervals, each a cycle on time that would have found MVP idle.
        """
        sleep_while_unchanged(sim.hooks.post_step, self._hook, sim._clock, lambda: sim.settings.reso)

    def update(self, sim: SimulationCore) -> None:
        if not self._reschedule(sim):
            return
        if not self.active(sim):
            if self.following or self.pairs:
                self.release_all(sim)
            else:
                self._sleep(sim)
            return
        st = sim.settings
        if st.cd_method != "OFF":
            conf = detect(sim, st.zoner_m, st.zonedh_m, st.dtlook_s)
            # Replayed real traffic is an intruder only: it takes no resolution.
            keep = ~np.asarray(sim.view.noncooperative)[conf.own]
            own, intr = conf.own[keep], conf.intr[keep]
            if own.size:
                self._resolve(sim, conf, keep)
        else:
            own = intr = np.empty(0, dtype=np.int64)
        self._resume(sim, own, intr)

    def _resolve(self, sim: SimulationCore, conf: DirectedConflicts, keep: np.ndarray) -> None:
        view, st = sim.view, sim.settings
        ids = view.ids
        no_reso = np.array([a in self.no_reso for a in ids], dtype=bool)
        reso_off = np.array([a in self.reso_off for a in ids], dtype=bool)
        trk, gs, vs, alt_cmd = mvp_commands(sim, conf, keep, self.settings, st.zoner_m, st.zonedh_m, st.dtlook_s,
                                            no_reso, reso_off)
        coop = np.flatnonzero(~np.asarray(view.noncooperative))
        sim.command_resolution(coop, trk[coop], gs[coop], vs[coop], alt_cmd[coop])

    def _resume(self, sim: SimulationCore, own: np.ndarray, intr: np.ndarray) -> None:
        """Which aircraft follow the resolution from now on; those whose last pair ended resume their route."""
        view = sim.view
        ids = view.ids
        self.pairs.update(zip((ids[i] for i in own.tolist()), (ids[j] for j in intr.tolist())))
        if not self.pairs:
            return
        rpz = sim.settings.zoner_m
        change: dict[str, bool] = {}
        ended: set[tuple[str, str]] = set()
        for a, b in self.pairs:
            i, j = view.find(a), view.find(b)
            if i is None:
                ended.add((a, b))
                continue
            if j is not None and self._still_resolving(sim, i, j, rpz):
                change[a] = True
                continue
            change[a] = change.get(a, False)
            ended.add((a, b))
        self.pairs -= ended
        for acid, on in change.items():
            self._follow(sim, acid, on)

    def _still_resolving(self, sim: SimulationCore, i: int, j: int, rpz: float) -> bool:
        """Before CPA, within the protected radius, or a bouncing conflict (BlueSky's resumenav test)."""
        view = sim.view
        lat_i, lat_j = float(view.lat[i]), float(view.lat[j])
        dx = R_EARTH * np.radians(float(view.lon[j]) - float(view.lon[i])) * np.cos(0.5 * np.radians(lat_j + lat_i))
        dy = R_EARTH * np.radians(lat_j - lat_i)
        ux = float(view.gseast[j]) - float(view.gseast[i])
        uy = float(view.gsnorth[j]) - float(view.gsnorth[i])
        past_cpa = dx * ux + dy * uy > 0.0
        hdist = float(np.hypot(dx, dy))
        parallel = abs(_angle_difference(float(view.trk[i]), float(view.trk[j]))) < _BOUNCING_DEG
        bouncing = parallel and hdist < rpz * self.settings.factor_h
        return bool(not past_cpa or hdist < rpz or bouncing)

    def _follow(self, sim: SimulationCore, acid: str, on: bool) -> None:
        slot = sim.view.slot(acid)
        if on:
            if acid not in self.following:
                self.following.add(acid)
                self.resolutions += 1
                record_advisory(sim, acid, "resolution")
            sim.follow_resolution(slot, True)
            return
        self.following.discard(acid)
        sim.follow_resolution(slot, False)
        # Back on the route: direct to the best waypoint (BlueSky's findact), when there is a route.
        if len(sim.view.route(slot)):
            sim.resume_route(slot)

    def release_all(self, sim: SimulationCore) -> None:
        """Every aircraft back to its autopilot now (``RESO OFF``), no direct-to; pairs forgotten."""
        slots = [s for s in (sim.view.find(a) for a in self.following) if s is not None]
        if slots:
            sim.follow_resolution(np.array(slots, dtype=np.int64), False)
        self.following.clear()
        self.pairs.clear()

    def summary(self) -> dict[str, object]:
        return {"resolutions_started": self.resolutions, "settings": self.settings.describe()}


def mvp_commands(sim: SimulationCore, conf: DirectedConflicts, keep: np.ndarray, settings: MVPSettings, rpz_m: float,
                 hpz_m: float, dtlook_s: float, no_reso: np.ndarray | None = None,
                 reso_off: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """MVP's track [deg], ground speed, vertical speed [m/s] and altitude [m] for every aircraft, from the
    directed conflicts ``conf`` (rows ``keep``; BlueSky's cycle, :class:`MVPService`). ``no_reso``: aircraft
    nobody avoids, ``reso_off``: aircraft that avoid nobody (per slot; default none)."""
    return mvp_commands_on(sim.view, conf, keep, settings, rpz_m, hpz_m, dtlook_s, no_reso, reso_off)


def mvp_commands_on(view: Any, conf: DirectedConflicts, keep: np.ndarray, settings: MVPSettings, rpz_m: float,
                    hpz_m: float, dtlook_s: float, no_reso: np.ndarray | None = None,
                    reso_off: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`mvp_commands` on any traffic state: ``view`` has ``ids`` and the arrays of :class:`OwnState`
    (a :class:`~aamsim.traffic.view.TrafficView` or a :class:`~aamsim.snapshots.TrafficSnapshot`)."""
    n = len(view.ids)
    own, intr = conf.own[keep], conf.intr[keep]
    qdr = np.radians(conf.qdr_deg[keep])
    dist = conf.dist_m[keep]
    alt = np.asarray(view.alt)
    drel = np.column_stack([np.sin(qdr) * dist, np.cos(qdr) * dist, alt[intr] - alt[own]])
    vel = np.column_stack([view.gseast, view.gsnorth, view.vs])
    g = PairGeometry(own, intr, drel, vel[intr] - vel[own], conf.tcpa_s[keep], conf.tlos_s[keep])
    push, tsol = mvp_pairs(g, rpz_m * settings.factor_h, hpz_m * settings.factor_v, dtlook_s)
    none = np.zeros(n, dtype=bool)
    dv, tsolv = combine(n, g, push, tsol, settings, np.asarray(view.vs),
                        none if no_reso is None else no_reso, none if reso_off is None else reso_off)
    s = OwnState(view.gseast, view.gsnorth, view.vs, view.trk, view.gs, view.alt, view.selalt, view.ap_vs,
                 view.vmin, view.vmax, view.vsmin, view.vsmax)
    return commands(s, dv, tsolv, settings, dtlook_s)


def _angle_difference(a: float, b: float) -> float:
    """a - b wrapped to [-180, 180] [deg]."""
    d = a - b
    if d > 180.0:
        return d - 360.0
    if d < -180.0:
        return d + 360.0
    return d
