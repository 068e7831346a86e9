"""When a run without an end time stops (``aamsim run`` without ``--until``; :meth:`Simulation.run`).

BlueSky never stops by itself (its detached simulator ends only on ``QUIT``);
aamsim ends an open-ended run when the scenario can change nothing more. After
the scenario's last command (nothing is left in the queue of timed commands),
at each check (every chunk of :meth:`Simulation.run`, at most 60 s of sim time):

1. *Nothing left*: no conditional command waits, no service has work to come
   (a replayed recording) and no aircraft flies on a route (LNAV or VNAV):
   the run ends at once (:meth:`Simulation.is_quiescent`).
2. *No progress*: for :data:`STALL_LIMIT_S` nothing progressed: no aircraft
   was created or deleted, no conditional command fired, no aircraft reached
   a waypoint or came closer than ever (by :data:`APPROACH_M`) to its active
   one. Conditional commands still waiting then can no longer be expected to
   fire: an aircraft that missed its ``ATDIST`` point and flies on, or is
   pushed away from its route by conflict resolution, or circles a waypoint it
   cannot capture, would otherwise keep the run going for ever.
3. *Horizon*: :data:`DEFAULT_HORIZON_S` after the last command, whatever
   happens (longer than any flight), unless a service has work to come (live
   traffic runs until ``--until``, ``QUIT`` or a signal).

``--until`` (``until_s``) overrides all three.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from aamsim.simapi import SimulationCore

STALL_LIMIT_S = 3600.0
DEFAULT_HORIZON_S = 86_400.0
APPROACH_M = 1.0  # a new closest distance to the active waypoint counts when it is this much closer


@dataclass
class OpenEndWatch:
    """Decides, check by check, whether an open-ended run should stop (see the module docstring)."""

    idle_s: float = 0.0  # time without progress since the last command
    _layout: int = -1
    _conditions: int = -1
    _closest: dict[str, tuple[int, float]] = field(default_factory=dict)  # callsign: active waypoint, closest [m]

    def check(self, sim: SimulationCore, chunk_s: float) -> tuple[str, str] | None:
        """Called after each chunk of ``chunk_s`` seconds: ``(reason, message)`` to stop, or None to go on.

        ``reason`` is ``"nothing_left"``, ``"no_progress"`` or ``"horizon"``.
        """
        if len(sim.queue):
            self.idle_s = 0.0
            self._layout, self._conditions = -1, -1
            self._closest.clear()
            return None
        if sim.is_quiescent():
            return "nothing_left", ""
        pending = any(pending() for pending in sim.pending_work)
        if pending or self._progressed(sim):
            self.idle_s = 0.0
        else:
            self.idle_s += chunk_s
        tail = (f"{sim.view.n} aircraft still flying, {len(sim.conditions)} conditional command(s) never fired "
                "(use --until to run longer)")
        if self.idle_s >= STALL_LIMIT_S:
            return "no_progress", (f"stopped at sim time {sim.simt:.0f} s: nothing progressed for "
                                   f"{STALL_LIMIT_S:.0f} s after the scenario's last command (no aircraft created "
                                   "or deleted, no conditional command fired, no waypoint reached or approached); "
                                   + tail)
        last_us = sim.queue.last_due_us
        last_s = 0.0 if last_us is None else last_us / 1e6
        if not pending and sim.simt - last_s >= DEFAULT_HORIZON_S:
            return "horizon", (f"stopped at sim time {sim.simt:.0f} s: the default horizon, "
                               f"{DEFAULT_HORIZON_S / 3600:.0f} h after the last command (at {last_s:.0f} s); "
                               + tail)
        return None

    def _progressed(self, sim: SimulationCore) -> bool:
        """True when something changed since the previous check (and remembers the state for the next)."""
        view = sim.view
        moved = view.layout_version != self._layout or len(sim.conditions) != self._conditions
        self._layout, self._conditions = view.layout_version, len(sim.conditions)
        lnav = np.flatnonzero(np.asarray(view.lnav))
        dist = np.asarray(view.dist2wp)[lnav].tolist()
        ids = view.ids
        closest: dict[str, tuple[int, float]] = {}
        for k, slot in enumerate(lnav.tolist()):
            acid, active = ids[slot], int(view.route(slot).iactwp)
            before = self._closest.get(acid)
            if before is None or before[0] != active:
                moved = True  # on a route since the last check, or a waypoint reached
                closest[acid] = (active, dist[k])
            elif dist[k] < before[1] - APPROACH_M:
                moved = True
                closest[acid] = (active, dist[k])
            else:
                closest[acid] = before
        self._closest = closest
        return moved
