"""Raw column values (text, JSON values or Arrow arrays) -> SI :class:`StateReports`.

Vectorised where the values allow it (a column of numbers converts in one numpy call); a
column with blanks or text falls back to a per-value loop that finds the bad rows, so that a
malformed row is skipped and reported with its file and row and nothing else is lost.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import numpy as np

from aamsim.realtraffic.columns import TO_SI, ColumnPlan
from aamsim.realtraffic.reports import MAX_CALLSIGN_CHARS, BoolArray, FloatArray, SkipLog, SkippedRow, StateReports

Values = Sequence[Any] | np.ndarray
_ICAO24 = re.compile(r"~?[0-9a-f]{6}")
_TRUE = frozenset({"true", "t", "1", "yes"})
_FALSE = frozenset({"false", "f", "0", "no", ""})


@dataclass
class RawChunk:
    """Up to ``chunk_rows`` rows of one file: column name -> values, and where each row is."""

    columns: Mapping[str, Values]
    size: int
    where: Callable[[int], str]  # row index in the chunk -> "12" (line), "3:17" (response:state), ...


def _floats(values: Values) -> tuple[FloatArray, BoolArray]:
    """Values as float64 (None and blanks -> NaN) and a mask of values that are not numbers."""
    bad = np.zeros(len(values), dtype=bool)
    if isinstance(values, np.ndarray) and values.dtype.kind in "fiub":
        return values.astype(np.float64), bad
    try:
        return np.array(values, dtype=np.float64), bad
    except (TypeError, ValueError):
        pass  # blanks or text among the numbers: find them one by one below
    out = np.empty(len(values), dtype=np.float64)
    for i, value in enumerate(values):
        if value is None or value == "":
            out[i] = np.nan
            continue
        try:
            out[i] = float(value)
        except (TypeError, ValueError):
            out[i] = np.nan
            bad[i] = True
    return out, bad


def _epoch_seconds(values: Values, unit: str | None) -> tuple[FloatArray, BoolArray]:
    """Times as s since the epoch. ``unit="s"``: numbers are seconds. ``"epoch"``: numbers are s,
    ms, us or ns by magnitude (below 1e11, 1e14, 1e17, above), text is ISO 8601 (UTC unless it
    says otherwise)."""
    t, bad = _floats(values)
    if unit != "epoch":
        return t, bad
    for i in np.flatnonzero(bad):
        text = values[int(i)]
        if isinstance(text, str):
            try:
                stamp = datetime.fromisoformat(text.strip())
            except ValueError:
                continue
            if stamp.tzinfo is None:
                stamp = stamp.replace(tzinfo=UTC)
            t[i] = stamp.timestamp()
            bad[i] = False
    magnitude = np.abs(t)
    scale = np.where(magnitude < 1e11, 1.0, np.where(magnitude < 1e14, 1e-3, np.where(magnitude < 1e17, 1e-6, 1e-9)))
    return t * scale, bad


def _icao24(values: Values) -> tuple[np.ndarray, BoolArray]:
    out = []
    bad = np.zeros(len(values), dtype=bool)
    for i, value in enumerate(values):
        # A JSON writer that took an all-digit address for a number drops its leading zeros.
        text = str(value).strip().lower().zfill(6) if isinstance(value, int | np.integer | str) else ""
        if not _ICAO24.fullmatch(text):
            bad[i] = True
            text = ""
        out.append(text)
    return np.array(out, dtype="U7"), bad


def _callsigns(values: Values) -> tuple[np.ndarray, BoolArray]:
    """Callsigns, stripped, and a mask of those over :data:`MAX_CALLSIGN_CHARS` (left out as bad rows).

    The array's width is fixed: one 20,000-character callsign used to widen every row of the
    recording to it (a 2.5 MB file took 5.2 GB).
    """
    texts = ["" if v is None else str(v).strip() for v in values]
    bad = np.fromiter((len(t) > MAX_CALLSIGN_CHARS for t in texts), dtype=bool, count=len(texts))
    if bad.any():
        texts = ["" if b else t for t, b in zip(texts, bad.tolist())]
    return np.array(texts, dtype=f"U{MAX_CALLSIGN_CHARS}"), bad


def _bools(values: Values) -> tuple[BoolArray, BoolArray]:
    if isinstance(values, np.ndarray) and values.dtype.kind == "b":
        return values.copy(), np.zeros(len(values), dtype=bool)
    out = np.zeros(len(values), dtype=bool)
    bad = np.zeros(len(values), dtype=bool)
    for i, value in enumerate(values):
        if value is None or (isinstance(value, float) and np.isnan(value)):
            continue  # unknown: not known to be on the ground
        if isinstance(value, bool | int | np.bool_):
            out[i] = bool(value)
            continue
        text = str(value).strip().lower()
        if text in _TRUE:
            out[i] = True
        elif text not in _FALSE:
            bad[i] = True
    return out, bad


def normalise(chunk: RawChunk, plan: ColumnPlan, skips: SkipLog) -> StateReports:
    """The chunk's valid rows as SI reports in chunk order; every other row goes to ``skips``."""
    n = chunk.size
    problems: list[tuple[BoolArray, str]] = []

    def column(field: str) -> tuple[Values | None, str | None, str]:
        if field not in plan.fields:
            return None, None, ""
        name, unit = plan.fields[field]
        return chunk.columns[name], unit, name

    values, unit, name = column("t")
    assert values is not None  # the plan requires a time column
    t_s, bad = _epoch_seconds(values, unit)
    problems += [(bad, f"bad time in column {name!r}"), (~bad & ~np.isfinite(t_s), "no time")]
    values, _, name = column("icao24")
    assert values is not None
    icao24, bad = _icao24(values)
    problems.append((bad, f"bad icao24 in column {name!r}"))
    lat, bad_lat = _floats(chunk.columns[plan.fields["lat"][0]])  # the plan requires a position
    lon, bad_lon = _floats(chunk.columns[plan.fields["lon"][0]])
    problems += [
        (bad_lat | bad_lon, "bad latitude or longitude"),
        (~(bad_lat | bad_lon) & ~(np.isfinite(lat) & np.isfinite(lon)), "no position"),
        (np.abs(lat) > 90.0, "latitude outside [-90, 90]"),
        (np.abs(lon) > 180.0, "longitude outside [-180, 180]"),
    ]
    physical: dict[str, FloatArray] = {}
    for field in ("alt", "gs", "trk", "vs"):
        values, unit, name = column(field)
        if values is None:
            physical[field] = np.full(n, np.nan)
            continue
        number, bad = _floats(values)
        physical[field] = number * TO_SI[unit or "m"]
        problems.append((bad | np.isinf(number), f"bad value in column {name!r}"))  # NaN: unknown; inf: bad
    values, _, name = column("on_ground")
    on_ground, bad = _bools(values) if values is not None else (np.zeros(n, dtype=bool), np.zeros(n, dtype=bool))
    problems.append((bad, f"bad value in column {name!r}"))
    callsign_values, _, name = column("callsign")
    if callsign_values is not None:
        callsign, bad = _callsigns(callsign_values)
        problems.append((bad, f"callsign in column {name!r} over {MAX_CALLSIGN_CHARS} characters"))
    else:
        callsign = np.full(n, "", dtype="U8")

    keep = np.ones(n, dtype=bool)
    for mask, reason in problems:
        # The first problem of a row is its reason: one report per row, not one per symptom.
        for i in np.flatnonzero(mask & keep):
            skips.add(SkippedRow(plan.path, chunk.where(int(i)), reason))
        keep &= ~mask
    trk = np.mod(physical["trk"], 360.0)
    trk[trk >= 360.0] = 0.0  # np.mod gives 360.0 for a tiny negative angle
    reports = StateReports(
        t_s=t_s, icao24=icao24, callsign=callsign, lat=lat, lon=lon, alt_m=physical["alt"],
        gs_mps=physical["gs"], trk_deg=trk, vs_mps=physical["vs"], on_ground=on_ground,
    )
    return reports if keep.all() else reports.take(keep)
