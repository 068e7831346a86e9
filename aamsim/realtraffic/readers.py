"""Read a recording of real air traffic as SI state reports: the one entry point for every format.

>>> reports = read_reports("flights.csv.gz")            # all of it, sorted by time
>>> for block in RecordingReader("big.parquet"): ...     # or chunk by chunk, bounded memory

The contract (formats, column names, units, errors) is docs/real-traffic.md.
"""

from __future__ import annotations

import gzip
import io
import logging
from collections.abc import Collection, Iterator, Mapping, Sequence
from pathlib import Path
from typing import BinaryIO, Literal, TextIO

import numpy as np

from aamsim.realtraffic.columns import AltitudeChoice, ColumnPlan, plan_columns
from aamsim.realtraffic.normalise import RawChunk, normalise
from aamsim.realtraffic.reports import RecordingError, SkipLog, StateReports
from aamsim.realtraffic.sources import csv_chunks, json_chunks, parquet_chunks

logger = logging.getLogger(__name__)

Format = Literal["csv", "json", "parquet"]
_SUFFIXES: dict[str, Format] = {
    ".csv": "csv", ".json": "json", ".jsonl": "json", ".ndjson": "json", ".parquet": "parquet", ".pq": "parquet",
}
#: Rows per chunk: ~30 MB of raw CSV values or ~50 MB of JSON records in flight (measured, docs/real-traffic.md).
DEFAULT_CHUNK_ROWS = 16384


def detect_format(path: Path) -> Format:
    """From the file name (``.csv``, ``.json``, ``.jsonl``, ``.parquet``, each optionally ``.gz``),
    else from the first bytes (Parquet's ``PAR1``, JSON's ``[`` or ``{``, otherwise CSV)."""
    suffixes = [s.lower() for s in path.suffixes]
    if suffixes and suffixes[-1] == ".gz":
        suffixes.pop()
    if suffixes and suffixes[-1] in _SUFFIXES:
        return _SUFFIXES[suffixes[-1]]
    with _open_binary(path) as stream:
        head = stream.read(64)
    if head.startswith(b"PAR1"):
        return "parquet"
    return "json" if head.lstrip()[:1] in (b"[", b"{") else "csv"


def decoded_size_above(path: Path, limit: int) -> bool:
    """True when the recording holds more than ``limit`` bytes once decompressed.

    A ``.gz`` file is decompressed up to ``limit`` bytes and no further: its size on disk says
    little (1.3 MB of gzip held 20 million rows, 8.7 GB once read whole) and the size in its
    trailer is whatever the writer put there. A Parquet file's row groups state their
    uncompressed size; any other file is its size on disk.
    """
    if path.suffix.lower() == ".gz":
        seen = 0
        try:
            with gzip.open(path, "rb") as stream:
                while seen <= limit:
                    block = stream.read(1 << 16)
                    if not block:
                        break
                    seen += len(block)
        except (OSError, EOFError):  # a broken gzip: the reader reports it; what was decoded counts
            pass
        return seen > limit
    if detect_format(path) == "parquet":
        try:
            import pyarrow.parquet as pq

            meta = pq.ParquetFile(path).metadata
            size = sum(meta.row_group(k).total_byte_size for k in range(meta.num_row_groups))
        except (ImportError, OSError, ValueError):  # no pyarrow, or not Parquet: the reader says so
            size = path.stat().st_size
        return size > limit
    return path.stat().st_size > limit


def _open_binary(path: Path) -> BinaryIO:
    if path.suffix.lower() == ".gz":
        return gzip.open(path, "rb")  # type: ignore[return-value]  # GzipFile is a binary stream
    return open(path, "rb")


def _open_text(path: Path) -> TextIO:
    # utf-8-sig: spreadsheets write a byte-order mark before the header.
    return io.TextIOWrapper(_open_binary(path), encoding="utf-8-sig", newline="")


class RecordingReader:
    """Streams one recording as blocks of :class:`StateReports`.

    Each block holds up to ``chunk_rows`` rows of the file, normalised to SI and sorted by
    time within the block; blocks come in file order. Rows that cannot be read are skipped
    and kept in ``skipped`` (file, row, reason) and logged once per reason at the end.

    Args:
        path: the recording (see :func:`detect_format`).
        format: force ``"csv"``, ``"json"`` or ``"parquet"`` instead of detecting it.
        chunk_rows: rows per block.
        units: unit of a column whose name does not tell it, e.g. ``{"altitude": "m"}``.
        altitude: ``"baro"``, ``"geo"`` or ``"auto"`` (barometric when present).
        ignore_columns: more column names to read past; ``allow_unknown_columns`` reads past all.
        bbox: keep only reports inside (lat_min, lon_min, lat_max, lon_max) in deg; a box
            with lon_min > lon_max crosses the antimeridian.
        t_window: keep only reports with ``t0 <= t_s <= t1`` (s since the epoch).
    """

    def __init__(
        self,
        path: str | Path,
        *,
        format: Format | None = None,
        chunk_rows: int = DEFAULT_CHUNK_ROWS,
        units: Mapping[str, str] | None = None,
        altitude: AltitudeChoice = "auto",
        ignore_columns: Collection[str] = (),
        allow_unknown_columns: bool = False,
        bbox: tuple[float, float, float, float] | None = None,
        t_window: tuple[float, float] | None = None,
    ):
        if chunk_rows < 1:
            raise ValueError(f"chunk_rows must be >= 1, not {chunk_rows}")
        self.path = Path(path)
        if not self.path.is_file():
            raise RecordingError(str(path), "no such file")
        self.format: Format = format or detect_format(self.path)
        self.chunk_rows = chunk_rows
        self.bbox, self.t_window = bbox, t_window
        self.units, self.altitude = units, altitude
        self.ignore_columns, self.allow_unknown_columns = ignore_columns, allow_unknown_columns
        self.plan: ColumnPlan | None = None  # known once reading has started
        self.skipped = SkipLog()
        self.rows_read = 0  # rows turned into reports, before bbox / t_window
        self.rows_outside = 0  # reports left out by bbox / t_window (asked for, not lost)

    def _plan_for(self, names: Sequence[str]) -> ColumnPlan:
        self.plan = plan_columns(
            str(self.path), names, units=self.units, altitude=self.altitude,
            ignore_columns=self.ignore_columns, allow_unknown_columns=self.allow_unknown_columns,
        )
        logger.debug("%s: %s", self.path, self.plan.describe())
        return self.plan

    def _raw_chunks(self) -> Iterator[RawChunk]:
        name = str(self.path)
        if self.format == "parquet":
            yield from parquet_chunks(name, self._plan_for, self.chunk_rows)
            return
        with _open_text(self.path) as stream:
            try:
                if self.format == "csv":
                    yield from csv_chunks(name, stream, self._plan_for, self.chunk_rows, self.skipped)
                else:
                    lines = self.path.name.lower().removesuffix(".gz").endswith((".jsonl", ".ndjson"))
                    yield from json_chunks(name, stream, self._plan_for, self.chunk_rows, self.skipped, lines=lines)
            except (UnicodeDecodeError, gzip.BadGzipFile, EOFError) as err:
                raise RecordingError(name, f"cannot be read as {self.format} text: {err}") from err

    def __iter__(self) -> Iterator[StateReports]:
        # Each pass reads the file again: its counts start again too.
        self.skipped, self.rows_read, self.rows_outside = SkipLog(), 0, 0
        for raw in self._raw_chunks():
            assert self.plan is not None  # every source plans before its first chunk
            block = normalise(raw, self.plan, self.skipped)
            self.rows_read += len(block)
            kept = self._inside(block)
            self.rows_outside += len(block) - len(kept)
            if len(kept):
                yield kept.sorted_by_time()
        if self.skipped.total:
            logger.warning("%s: skipped %d rows:\n%s", self.path, self.skipped.total, self.skipped.summary())

    def _inside(self, block: StateReports) -> StateReports:
        keep = np.ones(len(block), dtype=bool)
        if self.bbox is not None:
            lat0, lon0, lat1, lon1 = self.bbox
            keep &= (block.lat >= lat0) & (block.lat <= lat1)
            if lon0 <= lon1:
                keep &= (block.lon >= lon0) & (block.lon <= lon1)
            else:
                keep &= (block.lon >= lon0) | (block.lon <= lon1)
        if self.t_window is not None:
            keep &= (block.t_s >= self.t_window[0]) & (block.t_s <= self.t_window[1])
        return block if keep.all() else block.take(keep)


def read_reports(path: str | Path, **options: object) -> StateReports:
    """The whole recording as one block sorted by time (stable: equal times keep file order).

    Takes the keyword options of :class:`RecordingReader`; memory is ~120 bytes per kept
    report (use ``bbox``/``t_window`` to keep a big recording's share small).
    """
    reader = RecordingReader(path, **options)  # type: ignore[arg-type]
    return StateReports.concat(list(reader)).sorted_by_time()
