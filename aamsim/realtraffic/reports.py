"""The normalised output of every reader: SI state reports, and what a reader skipped.

One :class:`StateReports` is a block of reports as parallel numpy arrays (struct of arrays,
like the simulator's traffic) so that a recording of millions of rows costs ~120 bytes per
report in memory and track building is vectorised.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from aamsim.errors import AamsimError

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
StrArray = NDArray[np.str_]

#: The normalised columns, in order, with their units.
REPORT_FIELDS = {
    "t_s": "s since 1970-01-01 UTC (the recording's own clock)",
    "icao24": "lower-case 6-digit hex transponder address",
    "callsign": "text, stripped, at most 16 characters (MAX_CALLSIGN_CHARS); empty when unknown",
    "lat": "deg WGS84",
    "lon": "deg WGS84, in [-180, 180]",
    "alt_m": "m (barometric by default, see altitude=); NaN when unknown",
    "gs_mps": "m/s ground speed; NaN when unknown",
    "trk_deg": "deg true track over ground, [0, 360); NaN when unknown",
    "vs_mps": "m/s vertical rate, positive up; NaN when unknown",
    "on_ground": "bool; False when the source does not say",
}

#: Longest callsign a report keeps (OpenSky's are 8 characters); a row with a longer one is skipped.
MAX_CALLSIGN_CHARS = 16


class RecordingError(AamsimError):
    """A recording that cannot be read as a whole: unknown or ambiguous columns, mixed units,
    no position, broken JSON, unknown format. The message names the file and the column."""

    def __init__(self, path: str, message: str, column: str | None = None):
        self.path = path
        self.column = column
        self.message = message
        where = f"{path}: column {column!r}: " if column is not None else f"{path}: "
        super().__init__(where + message)


@dataclass(frozen=True)
class SkippedRow:
    """One row a reader did not turn into a report, and why.

    ``row`` is the 1-based line number for CSV and JSON-lines files (the header is line 1),
    the 1-based record number for JSON arrays and Parquet, and ``response:state`` for OpenSky
    REST responses (1-based both).
    """

    path: str
    row: str
    reason: str

    def __str__(self) -> str:
        return f"{self.path}:{self.row}: {self.reason}"


@dataclass
class SkipLog:
    """Every skipped row is counted by reason; the first ``keep`` are kept in full."""

    keep: int = 1000
    rows: list[SkippedRow] = field(default_factory=list)
    counts: Counter[str] = field(default_factory=Counter)

    def add(self, row: SkippedRow) -> None:
        self.counts[row.reason] += 1
        if len(self.rows) < self.keep:
            self.rows.append(row)

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def summary(self) -> str:
        """One line per reason, most frequent first: ``count x reason (first at file:row)``."""
        first: dict[str, SkippedRow] = {}
        for row in self.rows:
            first.setdefault(row.reason, row)
        lines = []
        for reason, count in self.counts.most_common():
            at = f" (first at {first[reason].path}:{first[reason].row})" if reason in first else ""
            lines.append(f"{count} x {reason}{at}")
        return "\n".join(lines)


@dataclass(frozen=True)
class Motion:
    """Position and motion in SI, one value per report or per track (see ``REPORT_FIELDS``)."""

    lat: FloatArray
    lon: FloatArray
    alt_m: FloatArray
    gs_mps: FloatArray
    trk_deg: FloatArray
    vs_mps: FloatArray


MOTION_FIELDS = ("lat", "lon", "alt_m", "gs_mps", "trk_deg", "vs_mps")


@dataclass(frozen=True)
class StateReports(Motion):
    """A block of normalised state reports (all arrays the same length); see ``REPORT_FIELDS``."""

    t_s: FloatArray
    icao24: StrArray
    callsign: StrArray
    on_ground: BoolArray

    def __post_init__(self) -> None:
        sizes = {name: len(getattr(self, name)) for name in REPORT_FIELDS}
        if len(set(sizes.values())) > 1:
            raise ValueError(f"StateReports arrays differ in length: {sizes}")

    def __len__(self) -> int:
        return len(self.t_s)

    def take(self, index: NDArray[np.intp] | BoolArray | slice) -> StateReports:
        """The reports at ``index`` (an index array, a boolean mask or a slice)."""
        return StateReports(**{name: getattr(self, name)[index] for name in REPORT_FIELDS})

    def sorted_by_time(self) -> StateReports:
        """Stable sort by time: reports with equal times keep their file order."""
        order = np.argsort(self.t_s, kind="stable")
        return self.take(order)

    @staticmethod
    def empty() -> StateReports:
        floats = np.zeros(0, dtype=np.float64)
        return StateReports(
            t_s=floats, icao24=np.zeros(0, dtype="U6"), callsign=np.zeros(0, dtype="U8"),
            lat=floats, lon=floats, alt_m=floats, gs_mps=floats, trk_deg=floats, vs_mps=floats,
            on_ground=np.zeros(0, dtype=bool),
        )

    @staticmethod
    def concat(blocks: Iterable[StateReports]) -> StateReports:
        """One block holding ``blocks`` one after the other (no sorting)."""
        parts: Sequence[StateReports] = [b for b in blocks if len(b)]
        if not parts:
            return StateReports.empty()
        if len(parts) == 1:
            return parts[0]
        return StateReports(**{name: np.concatenate([getattr(b, name) for b in parts]) for name in REPORT_FIELDS})
