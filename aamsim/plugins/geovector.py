"""GEOVECTOR: limits on ground speed, track and vertical speed inside a shape (BlueSky's geovector plugin).

Load it as in BlueSky (``PLUGINS LOAD GEOVECTOR`` or ``PLUGIN GEOVECTOR``), define
a shape (BOX, POLY, POLYALT, CIRCLE), then::

    GEOVECTOR area, [gsmin, gsmax, trkmin, trkmax, vsmin, vsmax]   (kts, deg, fpm; empty: no limit)
    DELGEOVECTOR area

Once a second (BlueSky's plugin timer: at the load and every second after),
before the traffic moves, for every aircraft inside the shape:

* a selected speed below ``gsmin`` or above ``gsmax`` becomes that limit
  (the limit is a true airspeed, converted to CAS at the aircraft's
  altitude, as BlueSky does: no wind), with VNAV off;
* a track left of ``trkmin`` or right of ``trkmax`` (the interval runs
  clockwise from ``trkmin`` to ``trkmax``, so 355..5 is valid) is turned to
  that limit, with LNAV off;
* a vertical speed below ``vsmin`` or above ``vsmax`` becomes that limit,
  with VNAV off and a selected altitude 200 ft beyond the current one in the
  direction of the limit.

An aircraft leaving the shape gets back the LNAV and VNAV switches it had
when it entered. Two BlueSky slips are not reproduced
(docs/bluesky-differences.md): BlueSky switches VNAV off for every aircraft
*below* ``vsmax`` (a ``<`` for ``>``), and it ignores a track interval whose
minimum is 0 (``0`` is false in its test).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aamsim import aero
from aamsim.errors import CommandError
from aamsim.shapes import shapes_of
from aamsim.stack.argtypes import Heading, SpeedArg, Text, VSpeed
from aamsim.stack.registry import command
from aamsim.units import FT, KTS, Speed

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

TIMER_S = 1.0  # BlueSky's update_interval
_HOOK = "geovector"


@dataclass
class GeoVector:
    """Limits of one area: ground speed [m/s], track [deg], vertical speed [m/s]; None: no limit."""

    area: str
    gsmin: float | None = None
    gsmax: float | None = None
    trkmin: float | None = None
    trkmax: float | None = None
    vsmin: float | None = None
    vsmax: float | None = None
    inside: set[str] = field(default_factory=set)
    saved: dict[str, tuple[bool, bool]] = field(default_factory=dict)  # acid -> (LNAV, VNAV) at entry

    def describe(self) -> str:
        def show(lo: float | None, hi: float | None, scale: float, unit: str) -> str:
            fmt = (lambda v: "-" if v is None else f"{v / scale:g}")
            return f"{fmt(lo)}..{fmt(hi)} {unit}"

        return (f"{self.area}: gs {show(self.gsmin, self.gsmax, KTS, 'kts')}, "
                f"trk {show(self.trkmin, self.trkmax, 1.0, 'deg')}, vs {show(self.vsmin, self.vsmax, FT / 60.0, 'fpm')}")


def _degto180(angle: np.ndarray) -> np.ndarray:
    return (angle + 180.0) % 360.0 - 180.0


@dataclass
class GeoVectors:
    vectors: dict[str, GeoVector] = field(default_factory=dict)

    def apply(self, sim: CommandContext) -> None:
        """One tick of the plugin timer: apply every geovector whose shape exists."""
        shapes = shapes_of(sim)
        for name, vec in self.vectors.items():
            if name not in shapes:
                continue
            view = sim.view
            ids = list(view.ids)
            inside_mask = shapes.contains(name, view.lat, view.lon, view.alt)
            inside = {acid for acid, ok in zip(ids, inside_mask) if ok}
            for acid in sorted(inside - vec.inside):
                i = ids.index(acid)
                vec.saved[acid] = (bool(view.lnav[i]), bool(view.vnav[i]))
            for acid in sorted(vec.inside - inside):
                lnav_vnav = vec.saved.pop(acid, None)
                if lnav_vnav is not None and acid in view:
                    sim.set_navigation(acid, lnav=lnav_vnav[0], vnav=lnav_vnav[1])
            vec.inside = inside
            self._limit(sim, vec, inside_mask)

    @staticmethod
    def _limit(sim: CommandContext, vec: GeoVector, inside: np.ndarray) -> None:
        view = sim.view
        slots = np.flatnonzero(inside)
        if not len(slots):
            return
        alt = view.alt[slots]
        selspd = view.selspd[slots]  # compared as BlueSky does: the number, CAS or Mach
        for limit, below in ((vec.gsmin, True), (vec.gsmax, False)):
            if limit is None:
                continue
            cas = aero.tas2cas(np.full(len(slots), limit), alt)
            hit = selspd < cas if below else selspd > cas
            for k in np.flatnonzero(hit):
                sim.select_speed(int(slots[k]), Speed(float(cas[k])))
                sim.set_navigation(int(slots[k]), vnav=False)
            selspd = np.where(hit, cas, selspd)
        if vec.trkmin is not None and vec.trkmax is not None:
            trk = view.trk[slots]
            left = _degto180(trk - vec.trkmin) < 0.0
            right = _degto180(trk - vec.trkmax) > 0.0
            for k in np.flatnonzero(left | right):
                sim.select_heading(int(slots[k]), vec.trkmin if left[k] else vec.trkmax)
        for limit, below in ((vec.vsmin, True), (vec.vsmax, False)):
            if limit is None:
                continue
            vs = view.vs[slots]
            hit = vs < limit if below else vs > limit
            for k in np.flatnonzero(hit):
                slot = int(slots[k])
                sim.select_altitude(slot, float(view.alt[slot]) + float(np.sign(limit)) * 200.0 * FT, limit)


def _state(sim: CommandContext) -> GeoVectors:
    state = sim.features.get(GeoVectors)
    if state is None:
        raise CommandError("the GEOVECTOR plugin is not loaded (PLUGINS LOAD GEOVECTOR)")
    return state


def _speed(speed: Speed | None) -> float | None:
    # BlueSky reads the limits with its speed parser: knots to m/s; a Mach number stays a number.
    return None if speed is None else speed.value


@command("GEOVECTOR", group="shapes")
def geovector(sim: CommandContext, area: Text, gsmin: SpeedArg | None = None, gsmax: SpeedArg | None = None,
              trkmin: Heading | None = None, trkmax: Heading | None = None, vsmin: VSpeed | None = None,
              vsmax: VSpeed | None = None) -> str | None:
    """GEOVECTOR area, [gsmin, gsmax, trkmin, trkmax, vsmin, vsmax]: limits inside a shape (kts, deg, fpm)."""
    state = _state(sim)
    has_limits = any(v is not None for v in (gsmin, gsmax, vsmin, vsmax)) or (
        trkmin is not None and trkmax is not None)
    if not has_limits:
        if area in state.vectors:
            return state.vectors[area].describe()
        raise CommandError(f"No geovector found for {area}")
    lo_gs, hi_gs = _speed(gsmin), _speed(gsmax)
    if lo_gs is not None and hi_gs is not None:
        lo_gs, hi_gs = min(lo_gs, hi_gs), max(lo_gs, hi_gs)
    lo_vs, hi_vs = vsmin, vsmax
    if lo_vs is not None and hi_vs is not None:
        lo_vs, hi_vs = min(lo_vs, hi_vs), max(lo_vs, hi_vs)
    state.vectors.pop(area, None)
    state.vectors[area] = GeoVector(area, lo_gs, hi_gs, trkmin, trkmax, lo_vs, hi_vs)
    return None


@command("DELGEOVECTOR", group="shapes")
def delgeovector(sim: CommandContext, area: Text) -> str:
    """DELGEOVECTOR area: remove the geovector of an area."""
    if _state(sim).vectors.pop(area, None) is None:
        raise CommandError(f"No geovector found for {area}")
    return f"Deleted geovector specification for {area}"


def init_plugin(sim: CommandContext) -> GeoVectors:
    state = sim.features.add(GeoVectors())
    sim.commands.add(geovector)
    sim.commands.add(delgeovector)
    sim.hooks.reset.add(lambda s: state.vectors.clear(), name=f"{_HOOK}-reset")
    # BlueSky's preupdate timer fires at once and then every second: before the traffic moves.
    sim.hooks.pre_step.add(state.apply, interval_s=TIMER_S, name=_HOOK, start_us=round(sim.simt * 1e6))
    return state
