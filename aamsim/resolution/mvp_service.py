"""BlueSky's conflict resolution cycle with Modified Voltage Potential, switched on by ``RESO MVP``.

At every conflict-detection cycle (``DT ASAS``, 1 s; right after the check of
:mod:`aamsim.conflicts.service`), while ``RESO MVP`` is on, as BlueSky 1.1.1's
``ConflictResolution.update``:

1. when the check found conflict pairs, MVP (:mod:`aamsim.resolution.mvp`)
   computes a track, ground speed, vertical speed and altitude for every
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
from typing import TYPE_CHECKING

import numpy as np

from aamsim.conflicts.service import ConflictState
from aamsim.metrics import record_advisory
from aamsim.resolution.mvp import MVPSettings, OwnState, PairGeometry, combine, commands, mvp_pairs
from aamsim.units import NM

if TYPE_CHECKING:
    from aamsim.simulation import Simulation

METHOD = "MVP"
_R_EARTH = 6371000.0  # BlueSky's radius in its flat-earth pair formulas
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

    def attach(self, sim: Simulation) -> None:
        # Right after the conflict check (priority 10), on the same interval: BlueSky's CD then CR.
        sim.hooks.post_step.add(self.update, interval_s=lambda: sim.settings.cd_interval_s, name="mvp",
                                priority=15)
        sim.hooks.deleted.add(self.on_deleted, name="mvp.deleted")
        sim.hooks.reset.add(self.on_reset, name="mvp.reset")

    @staticmethod
    def active(sim: Simulation) -> bool:
        return sim.settings.reso.upper() == METHOD

    def on_reset(self, sim: Simulation) -> None:
        self.settings = MVPSettings()
        self.pairs.clear()
        self.no_reso.clear()
        self.reso_off.clear()
        self.following.clear()
        self.resolutions = 0

    def on_deleted(self, sim: Simulation, slot: int, record: object) -> None:
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
    def update(self, sim: Simulation) -> None:
        if not self.active(sim):
            if self.following or self.pairs:
                self.release_all(sim)
            return
        state = sim.services.conflicts.state if sim.services is not None else None
        own, intr = self._directed_pairs(sim, state)
        if own.size:
            assert state is not None
            self._resolve(sim, state, own, intr)
        self._resume(sim, own, intr)

    def _directed_pairs(self, sim: Simulation, state: ConflictState | None) -> tuple[np.ndarray, np.ndarray]:
        """The check's conflict pairs in both orders (ownship, intruder), by ownship then intruder slot.

        Replayed real traffic is an intruder only: it takes no resolution.
        """
        if state is None or state.pi.size == 0 or state.ids != sim.view.ids:
            empty = np.empty(0, dtype=np.int64)
            return empty, empty
        own = np.concatenate([state.pi, state.pj])
        intr = np.concatenate([state.pj, state.pi])
        keep = ~sim.view.noncooperative[own]
        own, intr = own[keep], intr[keep]
        order = np.lexsort((intr, own))
        return own[order], intr[order]

    def _geometry(self, sim: Simulation, state: ConflictState, own: np.ndarray, intr: np.ndarray) -> PairGeometry:
        """Relative positions as BlueSky's detection gives them (bearing and distance, flat earth)."""
        view = sim.view
        lat, lon = np.asarray(view.lat), np.asarray(view.lon)
        dlat = np.radians(lat[intr] - lat[own])
        dlon = np.radians(((lon[intr] - lon[own]) + 180) % 360 - 180)
        cavelat = np.cos(np.radians(lat[intr] + lat[own]) * 0.5)
        dist = _R_EARTH * np.sqrt(dlat * dlat + dlon * dlon * (cavelat * cavelat)) / NM * NM
        qdr = np.radians(np.degrees(np.arctan2(dlon * cavelat, dlat)) % 360.0)
        alt = np.asarray(view.alt)
        drel = np.column_stack([np.sin(qdr) * dist, np.cos(qdr) * dist, alt[intr] - alt[own]])
        vel = np.column_stack([view.gseast, view.gsnorth, view.vs])
        vrel = vel[intr] - vel[own]
        # The check's pairs are (i < j); its times are the same seen from either side.
        index = {(int(a), int(b)): k for k, (a, b) in enumerate(zip(state.pi.tolist(), state.pj.tolist()))}
        rows = np.array([index[(min(a, b), max(a, b))] for a, b in zip(own.tolist(), intr.tolist())], dtype=np.int64)
        return PairGeometry(own, intr, drel, vrel, state.tcpa_s[rows], state.tinconf_s[rows])

    def _resolve(self, sim: Simulation, state: ConflictState, own: np.ndarray, intr: np.ndarray) -> None:
        view, st = sim.view, sim.settings
        n = view.n
        g = self._geometry(sim, state, own, intr)
        push, tsol = mvp_pairs(g, st.zoner_m * self.settings.factor_h, st.zonedh_m * self.settings.factor_v,
                               st.dtlook_s)
        ids = view.ids
        no_reso = np.array([a in self.no_reso for a in ids], dtype=bool)
        reso_off = np.array([a in self.reso_off for a in ids], dtype=bool)
        dv, tsolv = combine(n, g, push, tsol, self.settings, np.asarray(view.vs), no_reso, reso_off)
        s = OwnState(view.gseast, view.gsnorth, view.vs, view.trk, view.gs, view.alt, view.selalt, view.ap_vs,
                     view.vmin, view.vmax, view.vsmin, view.vsmax)
        trk, gs, vs, alt = commands(s, dv, tsolv, self.settings, st.dtlook_s)
        coop = np.flatnonzero(~view.noncooperative)
        sim.command_resolution(coop, trk[coop], gs[coop], vs[coop], alt[coop])

    def _resume(self, sim: Simulation, own: np.ndarray, intr: np.ndarray) -> None:
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

    def _still_resolving(self, sim: Simulation, i: int, j: int, rpz: float) -> bool:
        """Before CPA, within the protected radius, or a bouncing conflict (BlueSky's resumenav test)."""
        view = sim.view
        lat_i, lat_j = float(view.lat[i]), float(view.lat[j])
        dx = _R_EARTH * np.radians(float(view.lon[j]) - float(view.lon[i])) * np.cos(0.5 * np.radians(lat_j + lat_i))
        dy = _R_EARTH * np.radians(lat_j - lat_i)
        ux = float(view.gseast[j]) - float(view.gseast[i])
        uy = float(view.gsnorth[j]) - float(view.gsnorth[i])
        past_cpa = dx * ux + dy * uy > 0.0
        hdist = float(np.hypot(dx, dy))
        parallel = abs(_angle_difference(float(view.trk[i]), float(view.trk[j]))) < _BOUNCING_DEG
        bouncing = parallel and hdist < rpz * self.settings.factor_h
        return bool(not past_cpa or hdist < rpz or bouncing)

    def _follow(self, sim: Simulation, acid: str, on: bool) -> None:
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

    def release_all(self, sim: Simulation) -> None:
        """Every aircraft back to its autopilot now (``RESO OFF``), no direct-to; pairs forgotten."""
        slots = [s for s in (sim.view.find(a) for a in self.following) if s is not None]
        if slots:
            sim.follow_resolution(np.array(slots, dtype=np.int64), False)
        self.following.clear()
        self.pairs.clear()

    def summary(self) -> dict[str, object]:
        return {"resolutions_started": self.resolutions, "settings": self.settings.describe()}


def _angle_difference(a: float, b: float) -> float:
    """a - b wrapped to [-180, 180] [deg]."""
    d = a - b
    if d > 180.0:
        return d - 360.0
    if d < -180.0:
        return d + 360.0
    return d
