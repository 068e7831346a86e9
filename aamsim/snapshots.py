"""The snapshot stream: frozen copies of the traffic, published to subscribers on a sim-time period.

A :class:`TrafficSnapshot` is what a consumer outside the simulator sees of
the traffic at one instant: the callsigns and the state arrays (SI units),
copied and read-only, so it can be kept, queued to another thread (a web
viewer) or sent over a socket (the bridge's ``state`` operation) while the
simulation goes on. The trajectory recorder, the bridge and a viewer all
consume it; none reaches into the traffic arrays.

:class:`SnapshotStream` publishes one: ``stream.subscribe(fn, period_s)``
calls ``fn(snapshot)`` every ``period_s`` of sim time, after the traffic moved
(a post-step observer; ``phase="pre_step"`` samples after the commands due
now, before the traffic moves, as the trajectory recorder does). Subscribers
due at the same moment share one snapshot.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.conflicts.separation import SeparationStandard
from aamsim.traffic.view import PUBLIC_FLAGS, PUBLIC_FLOATS

if TYPE_CHECKING:
    from collections.abc import Callable

    from aamsim.simapi import SimulationCore

SNAPSHOT_FIELDS = ("lat", "lon", "alt", "hdg", "trk", "tas", "cas", "gs", "vs")
# What a snapshot may hold: the public float fields, and the public flags as 1.0 / 0.0 (e.g. ``rotor``,
# which says whether an aircraft's envelope speeds are TAS or CAS).
FIELD_MEANINGS: dict[str, str] = {**PUBLIC_FLOATS, **{k: f"{v} (1.0 / 0.0)" for k, v in PUBLIC_FLAGS.items()}}


@dataclass(frozen=True)
class TrafficSnapshot:
    """The traffic at ``simt``: ``ids`` and one read-only array per field of ``fields`` (SI units).

    ``separation``: the simulation's separation standard at ``simt`` (``sim.separation_standard``),
    which the baselines measure their protected zones against; None when the taker did not add it.
    """

    simt: float
    ids: tuple[str, ...]
    fields: tuple[str, ...]
    values: np.ndarray  # (len(fields), len(ids)), read-only
    separation: SeparationStandard | None = None

    def __len__(self) -> int:
        return len(self.ids)

    def __getattr__(self, name: str) -> np.ndarray:
        if name.startswith("_") or name in ("fields", "values", "separation"):  # during copy/unpickle, before the fields exist
            raise AttributeError(name)
        try:
            row = self.fields.index(name)
        except ValueError:
            raise AttributeError(f"a traffic snapshot has no field {name!r}; it has {', '.join(self.fields)}") \
                from None
        column: np.ndarray = self.values[row]
        return column

    def columns(self, names: tuple[str, ...]) -> np.ndarray:
        """Several fields as a new ``(len(names), n)`` array."""
        return self.values[[self.fields.index(x) for x in names]]

    def as_dict(self, names: tuple[str, ...] | None = None) -> dict[str, Any]:
        """``simt``, ``ids`` (list) and float64 arrays by field name (a new array each)."""
        out: dict[str, Any] = {"simt": self.simt, "ids": list(self.ids)}
        for name in names or self.fields:
            out[name] = np.array(getattr(self, name), dtype=np.float64)
        return out


def take_snapshot(sim: SimulationCore, fields: tuple[str, ...] = SNAPSHOT_FIELDS,
                  separation: SeparationStandard | None = None) -> TrafficSnapshot:
    """A frozen copy of the traffic now (with ``separation``, the standard it is read against, when given)."""
    unknown = [x for x in fields if x not in FIELD_MEANINGS]
    if unknown:
        raise ValueError(f"unknown traffic field(s) {', '.join(unknown)}; known: {', '.join(FIELD_MEANINGS)}")
    view = sim.view
    if all(x in PUBLIC_FLOATS for x in fields):
        values = view.rows(fields)  # a new array: the copy that freezes the state
    else:
        values = np.array([np.asarray(getattr(view, x), dtype=np.float64) for x in fields]).reshape(len(fields),
                                                                                                    view.n)
    values.flags.writeable = False
    return TrafficSnapshot(sim.simt, view.ids, tuple(fields), values, separation)


class SnapshotStream:
    """Publishes traffic snapshots to subscribers (see the module docstring)."""

    def __init__(self, sim: SimulationCore, fields: tuple[str, ...] = SNAPSHOT_FIELDS):
        self.sim = sim
        self.fields = tuple(fields)
        self._last: tuple[int, int, str, TrafficSnapshot] | None = None

    def latest(self, phase: str = "post_step") -> TrafficSnapshot:
        """The snapshot of now (shared with the other subscribers due at this moment)."""
        sim = self.sim
        key = (sim.simt_us, sim._traffic.layout_version, phase)
        last = self._last
        if last is None or last[:3] != key:
            snap = take_snapshot(sim, self.fields)
            self._last = (*key, snap)
            return snap
        return last[3]

    def subscribe(self, fn: Callable[[TrafficSnapshot], None], period_s: float, *, name: str,
                  phase: str = "post_step", priority: int = 500) -> None:
        """Call ``fn(snapshot)`` every ``period_s`` of sim time (``phase``: ``post_step`` or ``pre_step``)."""
        if phase not in ("post_step", "pre_step"):
            raise ValueError(f"phase must be 'post_step' or 'pre_step', not {phase!r}")
        if not period_s > 0:
            raise ValueError(f"the snapshot period must be positive, not {period_s!r}")
        hooks = self.sim.hooks.post_step if phase == "post_step" else self.sim.hooks.pre_step
        hooks.add(lambda sim: fn(self.latest(phase)), interval_s=period_s, name=name, priority=priority)
