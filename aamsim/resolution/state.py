"""The kinematic state the detect-and-avoid logic reads: a simulation in process, or a traffic snapshot.

:class:`~aamsim.resolution.daa.DetectAndAvoid` reads the traffic through one small
read-only protocol, :class:`KinematicState`: a ``view`` of named per-slot arrays
(``ids``, ``n`` and the fields of :data:`DAA_FIELDS`) and the conflict geometry
(positions, velocities east/north/up and the local frame) of :func:`geometry_of`.
A simulation satisfies it (its traffic view; ``RESO DAA`` reads it so, unchanged);
so does :class:`SnapshotState`, a wrapper over an :class:`aamsim.snapshots.TrafficSnapshot`
of those fields, which crosses the bridge's wire. Both give the same float64 values
and run the same compiled geometry, so a policy built on the DAA logic decides the
same in process and over a socket.

The wind enters the DAA logic only as the along-track wind of now, ``gs - tas``
(a speed change keeps it), so a snapshot needs no wind field.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from aamsim.conflicts.grid import snapshot_arrays
from aamsim.conflicts.service import TrafficSnapshot as ConflictGeometry
from aamsim.conflicts.service import traffic_snapshot
from aamsim.units import R_EARTH

if TYPE_CHECKING:
    from aamsim.snapshots import TrafficSnapshot

# Positions and velocities (east, north, up), the order of aamsim.conflicts.grid.snapshot_arrays' rows.
KINEMATIC_FIELDS = ("lat", "lon", "alt", "gseast", "gsnorth", "vs")
# What the speed logic reads besides: speeds (the along-track wind is gs - tas), tracks, the envelope
# (``rotor``: its speeds are TAS, else CAS) and the acceleration limit.
DAA_FIELDS = (*KINEMATIC_FIELDS, "gs", "tas", "cas", "trk", "hdg", "vmin", "vmax", "rotor", "axmax")
# The heading / vertical-speed logic (aamsim.resolution.axes) also reads the vertical envelope.
AXIS_FIELDS = (*DAA_FIELDS, "vsmin", "vsmax")


class KinematicState(Protocol):
    """What the DAA logic reads: ``view``, named read-only arrays by slot with ``ids`` and ``n``."""

    @property
    def view(self) -> Any: ...


def conflict_geometry(snap: TrafficSnapshot) -> ConflictGeometry:
    """The conflict detection's view of a traffic snapshot: positions, velocities and the local flat frame.

    The same arrays :func:`aamsim.conflicts.service.traffic_snapshot` computes from the
    simulation (one compiled loop over the same float64 values), from a snapshot with the
    fields of :data:`KINEMATIC_FIELDS`.
    """
    matrix = np.ascontiguousarray(snap.columns(KINEMATIC_FIELDS), dtype=np.float64)
    rows = np.arange(len(KINEMATIC_FIELDS), dtype=np.int64)
    lat, lon, alt, u, v, w, x, y, err, *frame = snapshot_arrays(matrix, len(snap.ids), rows, R_EARTH)
    return ConflictGeometry(list(snap.ids), lat, lon, alt, u, v, w, x, y, err, tuple(frame))  # type: ignore[arg-type]


class SnapshotView:
    """A traffic snapshot read as a traffic view: ``ids``, ``n``, ``slot``, ``in`` and one array per field."""

    def __init__(self, snap: TrafficSnapshot):
        self._snap = snap
        self._slots = {a: i for i, a in enumerate(snap.ids)}

    @property
    def ids(self) -> tuple[str, ...]:
        return self._snap.ids

    @property
    def n(self) -> int:
        return len(self._snap.ids)

    def __len__(self) -> int:
        return len(self._snap.ids)

    def __contains__(self, acid: object) -> bool:
        return acid in self._slots

    def slot(self, acid: str) -> int:
        """Slot (snapshot column) of a callsign; KeyError naming it when absent."""
        try:
            return self._slots[acid]
        except KeyError:
            raise KeyError(f"aircraft {acid!r} is not in the traffic snapshot") from None

    def __getattr__(self, name: str) -> np.ndarray:
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self._snap, name)  # type: ignore[no-any-return]


class SnapshotState:
    """A :class:`KinematicState` over a traffic snapshot of (at least) :data:`DAA_FIELDS`."""

    def __init__(self, snap: TrafficSnapshot):
        missing = [x for x in DAA_FIELDS if x not in snap.fields]
        if missing:
            raise ValueError(f"the DAA logic reads the traffic field(s) {', '.join(missing)}, which the snapshot "
                             f"lacks (it has {', '.join(snap.fields)})")
        self.snapshot = snap
        self.view = SnapshotView(snap)
        self._geometry: ConflictGeometry | None = None

    @property
    def simt(self) -> float:
        return self.snapshot.simt

    def conflict_geometry(self) -> ConflictGeometry:
        """The snapshot's conflict geometry (computed once)."""
        if self._geometry is None:
            self._geometry = conflict_geometry(self.snapshot)
        return self._geometry


def geometry_of(state: Any) -> ConflictGeometry:
    """Positions, velocities and the local frame of every aircraft of ``state`` (a simulation or a snapshot)."""
    if isinstance(state, SnapshotState):
        return state.conflict_geometry()
    return traffic_snapshot(state)
