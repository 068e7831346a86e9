"""The DAA alerting and resolution service, switched on by ``RESO DAA``.

Every ``interval_s`` (1 s) while ``RESO DAA`` is on, the service

1. computes every aircraft's alert level (:class:`~aamsim.resolution.daa.DetectAndAvoid`);
2. gives each aircraft at or above the resolution level (corrective by default)
   whose speed loses well clear a **speed advisory**: the conflict-free ground
   speed of its envelope closest to the current one, flown as a selected CAS
   (BlueSky's ``SPD``); of a pair, the aircraft that passes first keeps or gains
   speed and the other slows (:meth:`DetectAndAvoid.sides`), except at the
   warning level; the aircraft's own selected speed and VNAV speed mode are
   noted first;
3. holds each advisory while the aircraft is alerted or its noted speed would
   still lose well clear, replacing it only when the held speed itself comes to
   lose well clear (a new intruder, a manoeuvring one);
4. resumes the noted speed (and VNAV speed control) once clear of conflict:
   no alert at the resolution level and the noted speed conflict-free (of two
   nearby aircraft ready at once, one resumes first: :meth:`DetectAndAvoid.resume_order`).

Each advisory issued (a new or a replaced one) is counted in the flight's
advisories (the operational metric ``alert_rate_per_flight_hour``); the alerts
raised per level are counted in :attr:`DAAService.alert_counts`.
``RESO OFF`` releases every advisory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aamsim.metrics import record_advisory
from aamsim.resolution.daa import LEVEL_NAMES, DetectAndAvoid
from aamsim.units import Speed

if TYPE_CHECKING:
    from aamsim.simulation import Simulation

METHOD = "DAA"


@dataclass
class Advisory:
    """A speed advisory held by one aircraft."""

    cas_mps: float  # the advised CAS
    gs_mps: float  # the ground speed it was chosen for
    resume: Speed  # the aircraft's own selected speed, resumed when clear
    resume_vnav_speed: bool
    since_s: float


@dataclass
class DAAService:
    """Per-simulation DAA alerting and speed resolutions (see the module docstring)."""

    daa: DetectAndAvoid = field(default_factory=DetectAndAvoid)
    advisories: dict[str, Advisory] = field(default_factory=dict)
    levels: dict[str, int] = field(default_factory=dict)  # alert level of each alerted aircraft at the last cycle
    alert_counts: dict[str, int] = field(default_factory=lambda: {n: 0 for n in LEVEL_NAMES[1:]})
    issued: int = 0  # advisories issued over the run
    _raised: dict[str, int] = field(default_factory=dict)  # the level each aircraft was last counted at

    def attach(self, sim: Simulation) -> None:
        # After the conflict check (priority 10): both see the same state.
        sim.hooks.post_step.add(self.update, interval_s=lambda: self.daa.params.interval_s, name="daa", priority=20)
        sim.hooks.deleted.add(self.on_deleted, name="daa.deleted")
        sim.hooks.reset.add(self.on_reset, name="daa.reset")

    @staticmethod
    def active(sim: Simulation) -> bool:
        return sim.settings.reso.upper() == METHOD

    def on_reset(self, sim: Simulation) -> None:
        self.advisories.clear()
        self.levels.clear()
        self._raised.clear()

    def on_deleted(self, sim: Simulation, slot: int, record: object) -> None:
        acid = sim.view.ids[slot]
        self.advisories.pop(acid, None)
        self.levels.pop(acid, None)
        self._raised.pop(acid, None)

    # ---------------------------------------------------------------- cycle
    def update(self, sim: Simulation) -> None:
        if not self.active(sim):
            if self.advisories:
                self.release_all(sim)
            return
        view = sim.view
        alerts = self.daa.alerts(sim)
        self._count_alerts(alerts.ids, alerts.level)
        resolve = self.daa.params.resolve_level
        alerted = alerts.level >= resolve
        held = np.array([a in self.advisories for a in alerts.ids], dtype=bool)
        slots = np.flatnonzero(alerted | held)
        if slots.size == 0:
            return
        bands = self.daa.gs_bands(sim, slots)
        need: list[int] = []
        ready: list[int] = []
        for i in slots.tolist():
            acid = view.ids[i]
            adv = self.advisories.get(acid)
            if adv is None:
                if bands.conflicts(i, float(view.gs[i])):
                    need.append(i)
                continue
            resume_gs = float(self.daa.gs_for(sim, np.array([i]), np.array([self._resume_cas(sim, i, adv)]))[0])
            if not alerted[i] and not bands.conflicts(i, resume_gs):
                ready.append(i)
            elif bands.conflicts(i, adv.gs_mps):
                need.append(i)
        if ready:
            go = self.daa.resume_order(sim, np.array(ready, dtype=np.int64))
            for i in np.array(ready)[go].tolist():
                self._release(sim, view.ids[i], self.advisories[view.ids[i]])
        if need:
            idx = np.array(need, dtype=np.int64)
            gs, cas = self.daa.resolutions(sim, idx, bands, self.daa.sides(sim, alerts, idx))
            for i, g, c in zip(idx.tolist(), gs.tolist(), cas.tolist()):
                if not math.isnan(g):  # NaN: passes first at its speed, or nothing avoids the recovery volume
                    self._advise(sim, i, g, c)

    def _count_alerts(self, ids: tuple[str, ...], level: np.ndarray) -> None:
        """Count each alert when it is raised or rises to a higher level."""
        now = {ids[i]: int(level[i]) for i in np.flatnonzero(level > 0).tolist()}
        for acid, lv in now.items():
            if lv > self._raised.get(acid, 0):
                self.alert_counts[LEVEL_NAMES[lv]] += 1
        self._raised = now
        self.levels = now

    def _advise(self, sim: Simulation, slot: int, gs: float, cas: float) -> None:
        view = sim.view
        acid = view.ids[slot]
        adv = self.advisories.get(acid)
        if adv is None:
            resume = Speed(float(view.selspd[slot]), bool(view.selspd_mach[slot]))
            adv = Advisory(cas, gs, resume, bool(view.vnav_speed[slot]), sim.simt)
            self.advisories[acid] = adv
        else:
            adv.cas_mps, adv.gs_mps = cas, gs
        sim.select_speed(slot, cas)
        self.issued += 1
        record_advisory(sim, acid, "speed")

    @staticmethod
    def _resume_cas(sim: Simulation, slot: int, adv: Advisory) -> float:
        if adv.resume.is_mach:
            from aamsim.aero import mach2cas

            return mach2cas(adv.resume.value, float(sim.view.alt[slot]))
        return adv.resume.value

    def _release(self, sim: Simulation, acid: str, adv: Advisory) -> None:
        del self.advisories[acid]
        sim.select_speed(acid, adv.resume)
        if adv.resume_vnav_speed:
            sim.set_navigation(acid, vnav_speed=True)

    def release_all(self, sim: Simulation) -> None:
        """Resume every aircraft's own speed (``RESO OFF``)."""
        for acid, adv in list(self.advisories.items()):
            if acid in sim.view:
                self._release(sim, acid, adv)
        self.advisories.clear()

    def summary(self) -> dict[str, object]:
        """Counts for the run's summary."""
        return {"advisories_issued": self.issued, "alerts": dict(self.alert_counts),
                "params": {k: v for k, v in vars(self.daa.params).items()}}
