"""The ``daa`` baseline on use cases with heading and altitude advisories (``heading_altitude_sa``).

DO-365 / DAIDALUS alerting (:class:`aamsim.resolution.DetectAndAvoid`) and its
direction logic (:class:`aamsim.resolution.axes.AxisResolver`) on the use
case's own discrete actions, so its advisories are those a learned policy could
give:

* an agent alerted at the resolution level (corrective by default) whose
  trajectory loses well clear gets, of the actions whose manoeuvre (an instant
  turn to the action's track, a climb or descent to its altitude, then level
  flight; :func:`rlbridge.agents.manoeuvres.check_actions`) stays well clear over
  the look-ahead, the one on the coordinated sides (the turn and the vertical
  sense the pair's implicit coordination gives, as ``RESO DAA``) with the least
  manoeuvre (``|turn| / largest turn + |level change| / largest change``; ties:
  heading before altitude, the resolution axes' order); an agent already
  advised keeps its action while it stays well clear;
* none stays well clear: DAIDALUS's recovery, the action that keeps out of the
  recovery volume (the NMAC distances) longest and, of those that keep out
  for ``recovery_lookahead_s``, regains well clear soonest;
* the advisory is held while the agent is alerted or the resume action (back
  on the route, at the own altitude) would lose well clear; then it gets the
  resume action once, and no advisory after.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from aamsim.resolution import DetectAndAvoid
from aamsim.resolution.axes import HDG, VS, AxisResolver
from aamsim.resolution.service import most_urgent
from aamsim.resolution.state import KinematicState
from rlbridge.agents.manoeuvres import ActionTargets, check_actions


@dataclass
class ManoeuvreDAA:
    """Per-episode state of the heading / altitude DAA baseline (see the module docstring)."""

    daa: DetectAndAvoid
    held: dict[str, int] = field(default_factory=dict)  # agent -> the action it holds

    def act(self, sim: KinematicState, targets: ActionTargets, names: list[str],
            slots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Actions and advisory flags of the agents ``names`` (their ``slots``; ``targets``: a row each)."""
        p = self.daa.params
        actions = np.zeros(len(names), dtype=np.int64)
        advise = np.zeros(len(names), dtype=bool)
        alerts = self.daa.alerts(sim)
        alerted = alerts.level[slots] >= p.resolve_level
        losing = alerts.time_to_lowc_s[slots] <= p.lookahead_s
        involved = np.flatnonzero(alerted | np.array([a in self.held for a in names], dtype=bool))
        if involved.size == 0:
            return actions, advise
        inv = slots[involved]
        targets = _rows(targets, involved)
        first, last = check_actions(sim, inv, targets, p)
        free = first > p.lookahead_s
        resolve: list[int] = []
        for k, r in enumerate(involved.tolist()):
            acid = names[r]
            held = self.held.get(acid)
            if held is None:
                if alerted[r] and losing[r]:
                    resolve.append(k)
            elif alerted[r] or not free[k, targets.resume]:
                if free[k, held]:
                    actions[r], advise[r] = held, True  # still well clear: kept
                else:
                    resolve.append(k)
            else:  # clear of conflict: back on the route and level, once
                del self.held[acid]
                actions[r], advise[r] = targets.resume, True
        if not resolve:
            return actions, advise
        rows = np.array(resolve, dtype=np.int64)
        urgent = most_urgent(alerts, inv[rows])
        resolver = AxisResolver(self.daa)
        hsense = resolver.senses(sim, HDG, inv[rows], urgent)
        vsense = resolver.senses(sim, VS, inv[rows], urgent)
        rec_first = rec_last = None
        for q, k in enumerate(rows.tolist()):
            r = int(involved[k])
            i = int(inv[k])
            turn = (targets.trk[k] - float(sim.view.trk[i]) + 180.0) % 360.0 - 180.0
            climb = targets.alt[k] - float(sim.view.alt[i])
            cost = np.abs(turn) / max(float(np.abs(turn).max()), 1.0) + \
                np.abs(climb) / max(float(np.abs(climb).max()), 1.0)
            against = (turn * hsense[q] < -1e-6).astype(int) + (climb * vsense[q] < -1e-6).astype(int)
            level_change = (np.abs(climb) > 1.0).astype(int)  # heading before altitude (the axes' order)
            ok = np.flatnonzero(free[k])
            if ok.size:
                a = int(ok[np.lexsort((ok, level_change[ok], cost[ok], against[ok]))[0]])
            else:
                if rec_first is None:
                    rec_first, _ = check_actions(sim, inv[rows], _rows(targets, rows), p, recovery=True)
                    rec_last = last[rows]
                assert rec_last is not None
                keep_out = rec_first[q]
                clear = np.flatnonzero(keep_out > p.recovery_lookahead_s)
                if clear.size:  # regain well clear soonest
                    a = int(clear[np.lexsort((clear, cost[clear], against[clear], rec_last[q, clear]))[0]])
                else:  # keep out of the recovery volume longest
                    a = int(np.lexsort((np.arange(len(keep_out)), cost, -keep_out))[0])
            self.held[names[r]] = a
            actions[r], advise[r] = a, True
        return actions, advise


def _rows(targets: ActionTargets, rows: np.ndarray) -> ActionTargets:
    """The targets of some rows only."""
    return replace(targets, trk=targets.trk[rows], alt=targets.alt[rows])

