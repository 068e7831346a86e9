"""Trajectory recorder: samples every aircraft at multiples of the log period.

A sample at time T is the state after the simulation reached T and after the
commands due at T ran (an aircraft created at T appears with its initial
state, one deleted at T does not). Rows are buffered as arrays and written
in blocks, so memory stays bounded on long runs. A block is formatted and
written by a thread of the recorder's own while the simulation goes on (the
compiled formatter runs without the GIL): on two cores the file costs the run
little more than the copy of its rows. :meth:`TrajectoryRecorder.close` waits
for the last block.

A write that fails (a full disk, a file-size limit) does not end the run with a
traceback: the file is cut back to its last whole row, recording stops, and the
run stops with an error naming the file, so that the run directory is still
written and read back (``aamsim view`` of a half-written row used to fail).

Columns: ``id, simt, lat, lon, alt_m, tas_mps, cas_mps, gs_mps, trk_deg, vs_mps``
with 2, 7, 7, 3, 4, 4, 4, 4, 4 decimals (time in s, angles in degrees).
"""

from __future__ import annotations

import os
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, TYPE_CHECKING

import numpy as np

from aamsim.output.fastcsv import format_rows, pack_names

if TYPE_CHECKING:
    from aamsim.simulation import Simulation
    from aamsim.snapshots import TrafficSnapshot

TRAJECTORY_HEADER = "id,simt,lat,lon,alt_m,tas_mps,cas_mps,gs_mps,trk_deg,vs_mps\n"
_FIELDS = ("lat", "lon", "alt", "tas", "cas", "gs", "trk", "vs")
_DECIMALS = np.array([2, 7, 7, 3, 4, 4, 4, 4, 4], dtype=np.int64)
# Rows per block handed to the writer thread. Small enough that formatting overlaps the run on a
# second core (with 500,000, a run of 100 aircraft for an hour, 360,000 rows, formatted them all at
# the end: about 0.15 s of a 1.4 s process); large enough that a block's hand-over is negligible.
BLOCK_ROWS = 50_000


@dataclass
class TrajectoryRecorder:
    """Writes ``trajectories.csv``; attach with :meth:`attach`."""

    path: Path
    period_s: float = 1.0
    block_rows: int = BLOCK_ROWS  # rows per block formatted and written by the writer thread
    rows_written: int = 0
    failed: str | None = None  # why writing stopped (the OS error), None while it works
    _file: IO[bytes] | None = field(default=None, repr=False)
    _sim: Simulation | None = field(default=None, repr=False)
    _whole: int = 0  # bytes of the file that end with a whole row
    _names: list[str] = field(default_factory=list, repr=False)
    _name_ids: dict[str, int] = field(default_factory=dict, repr=False)
    _chunks: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list, repr=False)
    _buffered: int = 0
    _last_ids: tuple[str, ...] = field(default=(), repr=False)  # the callsigns of the last sample ...
    _last_index: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64), repr=False)  # ... numbered
    _writer: ThreadPoolExecutor | None = field(default=None, repr=False)  # formats and writes blocks, in order
    _written: Future[OSError | None] | None = field(default=None, repr=False)  # the last block handed to it
    _in_flight: int = 0  # rows of that block

    def attach(self, sim: Simulation) -> None:
        self._sim = sim
        # Unbuffered, so that what was written is known exactly; open while the recorder is attached.
        self._file = open(self.path, "wb", buffering=0)  # noqa: SIM115
        self._write(TRAJECTORY_HEADER.encode())
        sim.services.snapshots.subscribe(self.sample, self.period_s, name="trajectory-recorder",
                                             phase="pre_step", priority=900)

    def sample(self, snap: TrafficSnapshot) -> None:
        n = len(snap)
        if n == 0 or self._file is None:
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
        if self._buffered >= self.block_rows:
            self.flush()

    def flush(self) -> None:
        """Hand the buffered rows to the writer thread (they are in the file once :meth:`close` returns)."""
        if not self._chunks or self._file is None:
            return
        ids = np.concatenate([c[0] for c in self._chunks])
        cols = np.concatenate([c[1] for c in self._chunks], axis=1)
        name_bytes, offsets = pack_names(self._names)
        self._chunks.clear()
        self._buffered = 0
        if self._writer is None:
            self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="trajectories.csv")
        self._wait()  # one block in flight at a time: memory stays bounded
        if self._file is None:  # the block before failed: recording has stopped
            return
        self._written = self._writer.submit(_write_block, self._file, name_bytes, offsets, ids, cols)
        self._in_flight = len(ids)

    def _wait(self) -> None:
        """Collect the block in flight; a write that failed is handled here, on the simulation's thread."""
        if self._written is None:
            return
        written, self._written = self._written, None
        error = written.result()
        if error is not None:
            self._fail(error)
            return
        assert self._file is not None
        self._whole = self._file.tell()
        self.rows_written += self._in_flight

    def _write(self, data: bytes | memoryview) -> bool:
        """Write whole rows; on an OS error cut the file back to its last whole row and stop recording."""
        assert self._file is not None
        error = _write_all(self._file, data)
        if error is not None:
            self._fail(error)
            return False
        self._whole = self._file.tell()
        return True

    def _fail(self, exc: OSError) -> None:
        assert self._file is not None
        self.failed = exc.strerror or str(exc)
        try:
            os.ftruncate(self._file.fileno(), self._whole)  # shrinking works on a full disk
        except OSError:
            pass  # the rows up to the error stay; a reader leaves out a cut last line
        self._file.close()
        self._file = None
        if self._sim is not None:
            sim = self._sim
            text = (f"{self.path.name}: cannot write ({self.failed}); recording stopped and the run stops at "
                    f"t = {sim.simt:.2f} s; the file holds {self.rows_written:,} whole rows")
            sim.report("error", text)
            sim.run_outputs.write_failures.append(text)  # aamsim run exits 1 on them
            sim.quit_requested = True

    def sync(self) -> None:
        """Write every buffered row and hand them to the operating system (a run killed after this
        leaves them all in the file, complete)."""
        self.flush()
        self._wait()  # the writer thread's last block is in the file object before it is flushed
        if self._file is not None:
            self._file.flush()

    def close(self) -> None:
        try:
            self.flush()
            self._wait()
        finally:
            if self._writer is not None:
                self._writer.shutdown(wait=True)
                self._writer = None
            if self._file is not None:
                self._file.close()
                self._file = None


def _write_all(file: IO[bytes], data: bytes | memoryview) -> OSError | None:
    """Write all of ``data`` to an unbuffered file (which may take part of it per call); the error, if any."""
    view = memoryview(data).cast("B")
    try:
        while len(view):
            written = file.write(view)
            view = view[written or 0:]
    except OSError as exc:
        return exc
    return None


def _write_block(file: IO[bytes], name_bytes: np.ndarray, offsets: np.ndarray, ids: np.ndarray,
                 cols: np.ndarray) -> OSError | None:
    # Runs on the writer thread: the error is returned, and handled by the simulation's thread.
    return _write_all(file, format_rows(name_bytes, offsets, ids, cols, _DECIMALS).data)  # a view: no 50 MB copy
