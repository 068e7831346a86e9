"""The deletion area, experiment area and taxi switch of BlueSky's ``area`` plugin (AREA, EXP, TAXI).

BlueSky loads this plugin by default, so its commands are built in here.
Its rules, kept exactly:

* Once a second of simulated time (BlueSky's 1 s timer: every
  ``max(1, floor(1 s / dt))`` steps, at multiples of that period since the
  reset), after the traffic has moved, each aircraft is tested against the
  deletion area. An aircraft that was inside at the previous test and is
  outside now is deleted. An aircraft that has never been inside is never
  deleted (it may be created outside and fly in).
* ``AREA lat0 lon0 lat1 lon1 [top bottom]`` defines the box ``DELAREA``;
  ``AREA shape`` uses a shape defined with BOX, CIRCLE, POLY(ALT);
  ``AREA OFF`` stops the tests.
* ``EXP`` names the experiment area (``EXPAREA`` for a box). In BlueSky it
  only selects the flights written to its FLSTLOG file, which aamsim does not
  write (flights.csv holds every flight); it also switches the tests on.
* ``TAXI OFF [alt]``: an aircraft descending through ``alt`` (1500 ft by
  default) between two tests is deleted. The altitude it is compared with is
  the one of the previous test while TAXI is OFF, and its creation altitude
  before that, as in BlueSky.

A deleted aircraft's flight is closed as not arrived.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aamsim.errors import CommandError
from aamsim.shapes import shapes_of
from aamsim.units import FT

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

TIMER_S = 1.0  # BlueSky's timed_function(name='AREA', dt=1.0)
DEFAULT_TAXI_ALT_M = 1500.0 * FT
_HOOK = "deletion-area"


@dataclass
class DeletionArea:
    """State of the area plugin in one simulation."""

    active: bool = False
    delarea: str = ""
    exparea: str = ""
    taxi: bool = True  # TAXI ON (BlueSky's default): no deletion below the taxi altitude
    taxi_alt_m: float = DEFAULT_TAXI_ALT_M
    inside_del: set[str] = field(default_factory=set)  # callsigns inside the deletion area at the last test
    inside_exp: set[str] = field(default_factory=set)
    old_alt: dict[str, float] = field(default_factory=dict)  # altitude [m] compared by TAXI OFF
    deleted: int = 0

    def period_us(self, dt_s: float) -> int:
        steps = max(1, math.floor(TIMER_S / dt_s + 1e-9))
        return round(steps * dt_s * 1e6)

    def tick(self, sim: CommandContext) -> None:
        """One test of the 1 s timer: deletions by the areas and by TAXI OFF."""
        if sim.simt <= 0.0:
            return  # BlueSky's timer first fires one period after the reset
        view = sim.view
        ids = list(view.ids)
        doomed: list[str] = []
        if self.active:
            lat, lon, alt = view.lat, view.lon, view.alt
            shapes = shapes_of(sim)
            now_del = shapes.contains(self.delarea, lat, lon, alt) if self.delarea else np.zeros(len(ids), bool)
            now_exp = now_del if not self.exparea else shapes.contains(self.exparea, lat, lon, alt)
            inside_del = {acid for acid, inside in zip(ids, now_del) if inside}
            doomed = [acid for acid in ids if acid in self.inside_del and acid not in inside_del]
            self.inside_del = inside_del
            self.inside_exp = {acid for acid, inside in zip(ids, now_exp) if inside}
        self._delete(sim, doomed)
        if not self.taxi:
            view = sim.view
            alts = dict(zip(view.ids, (float(a) for a in view.alt)))
            low = [acid for acid, alt in alts.items()
                   if self.old_alt.get(acid, alt) >= self.taxi_alt_m and alt < self.taxi_alt_m]
            self.old_alt = alts
            self._delete(sim, low)

    def _delete(self, sim: CommandContext, acids: list[str]) -> None:
        for acid in acids:
            i = sim.view.find(acid)
            if i is not None:
                sim.delete_aircraft(i, arrived=False)
                self.deleted += 1

    def created(self, sim: CommandContext, slot: int) -> None:
        acid = sim.view.ids[slot]
        self.inside_del.discard(acid)
        self.inside_exp.discard(acid)
        self.old_alt[acid] = float(sim.view.alt[slot])

    def forget(self, sim: CommandContext, slot: int, record: object) -> None:
        acid = sim.view.ids[slot]
        self.inside_del.discard(acid)
        self.inside_exp.discard(acid)
        self.old_alt.pop(acid, None)

    def reset(self) -> None:
        self.active = False
        self.delarea = self.exparea = ""
        self.taxi = True
        self.taxi_alt_m = DEFAULT_TAXI_ALT_M
        self.inside_del.clear()
        self.inside_exp.clear()
        # BlueSky keeps its per-aircraft arrays through a reset only for aircraft that survive it: none.
        self.old_alt.clear()


def area_of(sim: CommandContext) -> DeletionArea:
    """The simulation's area state; the first use attaches its hooks."""
    area = sim.features.get(DeletionArea)
    if area is None:
        area = sim.features.add(DeletionArea())
        view = sim.view
        for slot, acid in enumerate(view.ids):  # aircraft created before the first AREA/EXP/TAXI
            area.old_alt[acid] = float(view.alt[slot])
        sim.hooks.created.add(area.created, name=f"{_HOOK}-created")
        sim.hooks.deleted.add(area.forget, name=f"{_HOOK}-deleted")
        sim.hooks.reset.add(lambda s: area.reset(), name=f"{_HOOK}-reset")
        period = area.period_us(sim.dt)
        now_us = round(sim.simt * 1e6)
        # BlueSky runs plugin updates after the traffic update and its conflict detection
        # (priority 10 here), before anything that samples the step's result.
        sim.hooks.post_step.add(area.tick, interval_s=lambda: area.period_us(sim.dt) / 1e6, name=_HOOK,
                                start_us=(now_us // period + 1) * period, priority=20)
    return area  # type: ignore[no-any-return]


def set_area(sim: CommandContext, args: list[float | str], experiment: bool) -> str:
    """AREA / EXP: a shape name, OFF/ON, or a box lat0, lon0, lat1, lon1, [top, bottom] (top/bottom in m)."""
    area = area_of(sim)
    what = "Experiment area" if experiment else "Deletion area"
    current = area.exparea if experiment else area.delarea
    if not args:
        return f"{what} is currently ON (name={current})" if area.active else f"{what} is currently OFF"
    first = args[0]
    if isinstance(first, str) and len(args) == 1:
        name = first.upper()
        if name in shapes_of(sim):
            if experiment:
                area.exparea = name
            else:
                area.delarea = name
            area.active = True
            return f"{what} is set to {name}"
        if name.startswith("OF"):
            area.active = False
            return f"{what} is switched OFF"
        if name.startswith("ON"):
            if not current:
                raise CommandError("No area defined.")
            area.active = True
            return f"{what} switched ON (name={current})"
        raise CommandError(f"shape {name} unknown: define it first (BOX, CIRCLE, POLY, POLYALT)")
    if all(isinstance(a, float) for a in args) and 4 <= len(args) <= 6:
        name = "EXPAREA" if experiment else "DELAREA"
        numbers = [float(a) for a in args]
        shapes_of(sim).define(name, "BOX", tuple(numbers[:4]), *numbers[4:6])
        if experiment:
            area.exparea = name
        else:
            area.delarea = name
        area.active = True
        return f"{what} is ON. Area name is: {name}"
    raise CommandError("Incorrect arguments: AREA shapename/OFF or AREA lat,lon,lat,lon,[top,bottom]")


def set_taxi(sim: CommandContext, on: bool, alt_m: float | None = None) -> None:
    """TAXI ON/OFF [alt]: with TAXI OFF, aircraft descending below ``alt_m`` (1500 ft) are deleted."""
    area = area_of(sim)
    area.taxi = on
    area.taxi_alt_m = DEFAULT_TAXI_ALT_M if alt_m is None else alt_m
