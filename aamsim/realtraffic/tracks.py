"""State reports -> per-aircraft tracks, and every track's state at any time, vectorised.

A track is one aircraft's airborne reports with no gap longer than ``max_gap_s``: on-ground
reports are left out and end the track (the aircraft landed), a longer gap splits it. A
replay asks :meth:`TrackSet.states_at` once per simulation step for all tracks at once: one
``searchsorted`` over every report of every track (keys ``track * stride + t``) and a dozen
array operations, so its cost grows with the number of aircraft shown, not with a Python loop.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from aamsim.realtraffic.reports import MOTION_FIELDS, FloatArray, Motion, StateReports, StrArray
from aamsim.units import R_EARTH

IntArray = NDArray[np.intp]
_KINEMATIC = MOTION_FIELDS


@dataclass(frozen=True)
class BuildSummary:
    """What :func:`build_tracks` left out, counted (nothing is dropped uncounted)."""

    reports: int
    on_ground: int  # on-ground reports (they end a track)
    no_altitude: int  # airborne reports without an altitude
    same_time: int  # a later report of the same aircraft at the same time replaced them
    short_tracks: int  # stretches with fewer than min_reports reports, left out
    in_short_tracks: int  # the reports those stretches had
    tracks: int


@dataclass(frozen=True)
class TrackStates(Motion):
    """The tracks flying at one time: ``index`` into the :class:`TrackSet`, and their SI state."""

    index: IntArray

    def __len__(self) -> int:
        return len(self.index)


def _wrap180(angle: FloatArray) -> FloatArray:
    return np.mod(angle + 180.0, 360.0) - 180.0


def wrap360(angle: FloatArray) -> FloatArray:
    """Angles in [0, 360): ``np.mod`` alone gives 360.0 for a tiny negative angle (-1e-300)."""
    wrapped = np.mod(angle, 360.0)
    return np.where(wrapped >= 360.0, 0.0, wrapped)


def interpolate(
    t0: FloatArray, t1: FloatArray, a: dict[str, FloatArray], b: dict[str, FloatArray], t: float | FloatArray
) -> dict[str, FloatArray]:
    """The state between reports ``a`` at ``t0`` and ``b`` at ``t1`` (arrays, one per track).

    Linear in lat, alt, speeds; longitude and track angle along the shorter arc (a track from
    350 to 10 deg passes 0, a flight over the antimeridian does not go round the world).
    """
    f = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    out = {name: a[name] + f * (b[name] - a[name]) for name in ("lat", "alt_m", "gs_mps", "vs_mps")}
    out["lon"] = _wrap180(a["lon"] + f * _wrap180(b["lon"] - a["lon"]))
    out["trk_deg"] = wrap360(a["trk_deg"] + f * _wrap180(b["trk_deg"] - a["trk_deg"]))
    return out


@dataclass(frozen=True)
class Track(Motion):
    """One aircraft's stretch of airborne reports (a view into its :class:`TrackSet`)."""

    icao24: str
    callsign: str
    segment: int  # 1, 2, ... when gaps or landings split the aircraft's reports
    t_s: FloatArray

    @property
    def label(self) -> str:
        """``icao24`` plus ``-2``, ``-3`` ... for the later stretches of the same aircraft."""
        return self.icao24 if self.segment == 1 else f"{self.icao24}-{self.segment}"

    def state_at(self, t: float) -> dict[str, float] | None:
        """The interpolated state at ``t`` (s, the recording's clock), None outside the track."""
        if not self.t_s[0] <= t <= self.t_s[-1]:
            return None
        j = min(int(np.searchsorted(self.t_s, t, side="right")) - 1, len(self.t_s) - 2)
        ends = [{name: getattr(self, name)[k : k + 1] for name in _KINEMATIC} for k in (j, j + 1)]
        state = interpolate(self.t_s[j : j + 1], self.t_s[j + 1 : j + 2], ends[0], ends[1], t)
        return {name: float(value[0]) for name, value in state.items()}


class TrackSet:
    """Tracks stored end to end (struct of arrays); track ``k`` is rows ``start[k]:start[k+1]``."""

    def __init__(
        self, rows: StateReports, start: IntArray, icao24: StrArray, callsign: StrArray, segment: IntArray,
        summary: BuildSummary,
    ):
        self.rows, self.start = rows, start
        self.icao24, self.callsign, self.segment, self.summary = icao24, callsign, segment, summary
        self.t_first = rows.t_s[start[:-1]] if len(icao24) else np.zeros(0)
        self.t_last = rows.t_s[start[1:] - 1] if len(icao24) else np.zeros(0)
        # Search keys: track k's times shifted into [k * stride, (k + 1) * stride).
        self._origin = float(self.t_first.min()) if len(icao24) else 0.0
        span = float(self.t_last.max()) - self._origin if len(icao24) else 0.0
        self._stride = span + 1.0
        owner = np.repeat(np.arange(len(icao24)), np.diff(start))
        self._keys = owner * self._stride + (rows.t_s - self._origin)

    def __len__(self) -> int:
        return len(self.icao24)

    def __getitem__(self, k: int) -> Track:
        rows = slice(int(self.start[k]), int(self.start[k + 1]))
        return Track(
            icao24=str(self.icao24[k]), callsign=str(self.callsign[k]), segment=int(self.segment[k]),
            t_s=self.rows.t_s[rows], **{name: getattr(self.rows, name)[rows] for name in _KINEMATIC},
        )

    def __iter__(self) -> Iterator[Track]:
        return (self[k] for k in range(len(self)))

    @property
    def labels(self) -> StrArray:
        """Every track's :attr:`Track.label`, by track index (what a replay names its aircraft)."""
        suffix = np.where(self.segment == 1, "", np.char.add("-", self.segment.astype(str)))
        return np.char.add(self.icao24.astype(str), suffix)

    @property
    def time_span(self) -> tuple[float, float]:
        """First and last report time of all tracks (s, the recording's clock)."""
        return (float(self.t_first.min()), float(self.t_last.max())) if len(self) else (np.nan, np.nan)

    def active_at(self, t: float) -> IntArray:
        """The tracks whose first report is at or before ``t`` and whose last is at or after."""
        return np.flatnonzero((self.t_first <= t) & (t <= self.t_last))

    def states_at(self, t: float) -> TrackStates:
        """The interpolated state of every track flying at ``t`` (s, the recording's clock)."""
        index = self.active_at(t)
        j = np.searchsorted(self._keys, index * self._stride + (t - self._origin), side="right") - 1
        # The last report of a track interpolates on its last segment with fraction 1.
        j = np.clip(j, self.start[index], self.start[index + 1] - 2)
        t_s = self.rows.t_s
        ends = [{name: getattr(self.rows, name)[k] for name in _KINEMATIC} for k in (j, j + 1)]
        state = interpolate(t_s[j], t_s[j + 1], ends[0], ends[1], t)
        return TrackStates(index=index, **state)


def build_tracks(
    reports: StateReports | Iterable[StateReports], *, max_gap_s: float = 60.0, min_reports: int = 2
) -> TrackSet:
    """Group reports per aircraft into airborne tracks.

    Args:
        reports: one block or the blocks of a :class:`~aamsim.realtraffic.RecordingReader`.
        max_gap_s: a gap longer than this between two reports of an aircraft splits its track.
        min_reports: stretches with fewer reports are left out (counted in the summary);
            at least 2, a track needs two reports to be interpolated.

    Reports at the same time as a later one of the same aircraft are replaced by it (repeated
    REST polls). Missing ground speed, track angle or vertical rate are filled from the
    nearest earlier report of the track (else the nearest later one); a track with none at
    all gets them from its positions.
    """
    if max_gap_s <= 0 or min_reports < 2:
        raise ValueError(f"need max_gap_s > 0 and min_reports >= 2, not {max_gap_s}, {min_reports}")
    rows = reports if isinstance(reports, StateReports) else StateReports.concat(list(reports))
    total = len(rows)
    rows = rows.take(np.lexsort((rows.t_s, rows.icao24)))  # per aircraft, by time, file order on ties
    # Landings so far, per aircraft: a change between two kept reports means it was on the ground.
    landings = np.cumsum(rows.on_ground)
    no_altitude = ~rows.on_ground & ~np.isfinite(rows.alt_m)
    keep = ~rows.on_ground & ~no_altitude
    rows, landings = rows.take(keep), landings[keep]
    later_same = np.zeros(len(rows), dtype=bool)  # (no reports at all is a valid, empty set of tracks)
    later_same[:-1] = (rows.icao24[:-1] == rows.icao24[1:]) & (rows.t_s[:-1] == rows.t_s[1:])
    rows, landings = rows.take(~later_same), landings[~later_same]
    n = len(rows)
    same_aircraft = np.concatenate([[False], rows.icao24[1:] == rows.icao24[:-1]]) if n else np.zeros(0, dtype=bool)
    continues = same_aircraft.copy()
    continues[1:] &= (np.diff(rows.t_s) <= max_gap_s) & (np.diff(landings) == 0)
    first = np.flatnonzero(~continues)
    bounds = np.append(first, n)
    sizes = np.diff(bounds)
    long_enough = sizes >= min_reports
    row_kept = np.repeat(long_enough, sizes)
    rows = rows.take(row_kept)
    sizes = sizes[long_enough]
    start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.intp)
    starts = start[:-1]
    icao24 = rows.icao24[starts]
    segment = _segment_numbers(icao24)
    rows = _fill_motion(rows, start)
    summary = BuildSummary(
        reports=total, on_ground=int(np.count_nonzero(~keep & ~no_altitude)), no_altitude=int(no_altitude.sum()),
        same_time=int(later_same.sum()), short_tracks=int((~long_enough).sum()),
        in_short_tracks=int((~row_kept).sum()), tracks=len(sizes),
    )
    return TrackSet(rows, start, icao24, _first_callsigns(rows.callsign, start), segment, summary)


def _segment_numbers(icao24: StrArray) -> IntArray:
    """1, 2, ... for successive tracks of the same aircraft (tracks are grouped per aircraft)."""
    new = np.concatenate([[True], icao24[1:] != icao24[:-1]]) if len(icao24) else np.zeros(0, dtype=bool)
    position = np.arange(len(icao24))
    return (position - np.maximum.accumulate(np.where(new, position, 0)) + 1).astype(np.intp)


def _first_callsigns(callsign: StrArray, start: IntArray) -> StrArray:
    out = []
    for k in range(len(start) - 1):
        names = callsign[start[k] : start[k + 1]]
        named = names[names != ""]
        out.append(named[0] if len(named) else "")
    return np.array(out, dtype=str)


def _fill_motion(rows: StateReports, start: IntArray) -> StateReports:
    """Missing gs / track / vertical rate from the nearest report of the same track, else derived."""
    n = len(rows)
    if n == 0:
        return rows
    track_start = np.zeros(n, dtype=bool)
    track_start[start[:-1]] = True
    track_end = np.zeros(n, dtype=bool)
    track_end[start[1:] - 1] = True
    derived: dict[str, FloatArray] = {}
    filled = {}
    for name in ("gs_mps", "trk_deg", "vs_mps"):
        values = getattr(rows, name)
        valid = np.isfinite(values)
        if valid.all():
            continue
        position = np.arange(n)
        earlier = np.maximum.accumulate(np.where(valid | track_start, position, 0))
        out = values[earlier]
        reverse = (valid | track_end)[::-1]
        later = n - 1 - np.maximum.accumulate(np.where(reverse, position, 0))[::-1]
        out = np.where(np.isfinite(out), out, values[later])
        if not np.isfinite(out).all():
            derived = derived or _derived_motion(rows, track_end)
            out = np.where(np.isfinite(out), out, derived[name])
        filled[name] = out
    if not filled:
        return rows
    return StateReports(**{**{name: getattr(rows, name) for name in rows.__dataclass_fields__}, **filled})


def _derived_motion(rows: StateReports, track_end: NDArray[np.bool_]) -> dict[str, FloatArray]:
    """Ground speed, track and vertical rate from each report to the next of its track (the last
    report of a track from the one before), flat-earth: tracks are sampled every few seconds."""
    n = len(rows)
    nxt = np.minimum(np.arange(n) + 1, n - 1)
    nxt = np.where(track_end, np.arange(n), nxt)
    prv = np.where(track_end, np.maximum(np.arange(n) - 1, 0), np.arange(n))
    dt = rows.t_s[nxt] - rows.t_s[prv]
    north = np.radians(rows.lat[nxt] - rows.lat[prv]) * R_EARTH
    east = np.radians(_wrap180(rows.lon[nxt] - rows.lon[prv])) * R_EARTH * np.cos(np.radians(rows.lat[prv]))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return {
            "gs_mps": np.hypot(north, east) / dt,
            "trk_deg": wrap360(np.degrees(np.arctan2(east, north))),
            "vs_mps": (rows.alt_m[nxt] - rows.alt_m[prv]) / dt,
        }
