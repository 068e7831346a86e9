"""Trajectory recorder: samples every aircraft at multiples of the log period.

A sample at time T is the state after the simulation reached T and after the
commands due at T ran (an aircraft created at T appears with its initial
state, one deleted at T does not). Rows are buffered as arrays and written
in blocks, so memory stays bounded on long runs.

Columns: ``id, simt, lat, lon, alt_m, tas_mps, cas_mps, gs_mps, trk_deg, vs_mps``
with 2, 7, 7, 3, 4, 4, 4, 4, 4 decimals (time in s, angles in degrees).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, TYPE_CHECKING

import numpy as np

from aamsim.output.fastcsv import format_rows, pack_names
from aamsim.services import services_of

if TYPE_CHECKING:
    from aamsim.simulation import Simulation
    from aamsim.snapshots import TrafficSnapshot

TRAJECTORY_HEADER = "id,simt,lat,lon,alt_m,tas_mps,cas_mps,gs_mps,trk_deg,vs_mps\n"
_FIELDS = ("lat", "lon", "alt", "tas", "cas", "gs", "trk", "vs")
_DECIMALS = np.array([2, 7, 7, 3, 4, 4, 4, 4, 4], dtype=np.int64)
_FLUSH_ROWS = 500_000


@dataclass
class TrajectoryRecorder:
    """Writes ``trajectories.csv``; attach with :meth:`attach`."""

    path: Path
    period_s: float = 1.0
    rows_written: int = 0
    _file: IO[bytes] | None = field(default=None, repr=False)
    _names: list[str] = field(default_factory=list, repr=False)
    _name_ids: dict[str, int] = field(default_factory=dict, repr=False)
    _chunks: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list, repr=False)
    _buffered: int = 0
    _last_ids: tuple[str, ...] = field(default=(), repr=False)  # the callsigns of the last sample ...
    _last_index: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64), repr=False)  # ... numbered

    def attach(self, sim: Simulation) -> None:
        self._file = open(self.path, "wb")
        self._file.write(TRAJECTORY_HEADER.encode())
        services_of(sim).snapshots.subscribe(self.sample, self.period_s, name="trajectory-recorder",
                                             phase="pre_step", priority=900)

    def sample(self, snap: TrafficSnapshot) -> None:
        n = len(snap)
        if n == 0:
            return
        if snap.ids == self._last_ids:  # the same aircraft as last time (most samples): the same numbers
            ids = self._last_index
        else:
            ids = np.empty(n, dtype=np.int64)
            for k, acid in enumerate(snap.ids):
                j = self._name_ids.get(acid)
                if j is None:
                    j = self._name_ids[acid] = len(self._names)
                    self._names.append(acid)
                ids[k] = j
            self._last_ids, self._last_index = snap.ids, ids
        cols = np.empty((len(_FIELDS) + 1, n))
        cols[0] = snap.simt
        cols[1:] = snap.columns(_FIELDS)
        self._chunks.append((ids, cols))
        self._buffered += n
        if self._buffered >= _FLUSH_ROWS:
            self.flush()

    def flush(self) -> None:
        if not self._chunks or self._file is None:
            return
        ids = np.concatenate([c[0] for c in self._chunks])
        cols = np.concatenate([c[1] for c in self._chunks], axis=1)
        name_bytes, offsets = pack_names(self._names)
        self._file.write(format_rows(name_bytes, offsets, ids, cols, _DECIMALS).data)  # a view: no 50 MB copy
        self.rows_written += len(ids)
        self._chunks.clear()
        self._buffered = 0

    def sync(self) -> None:
        """Write every buffered row and hand them to the operating system (a run killed after this
        leaves them all in the file, complete)."""
        self.flush()
        if self._file is not None:
            self._file.flush()

    def close(self) -> None:
        self.flush()
        if self._file is not None:
            self._file.close()
            self._file = None
