"""The tracks of a recording around a moving time, read ahead from a stream of report blocks.

A replay asks :meth:`TrackWindow.tracks_at` once per update. A small recording is read whole
at the first call (its order in the file does not matter: the traffic library's files are
grouped by flight). A big one (over ``stream_above_bytes`` decompressed) is streamed: blocks are
read until the reports reach ``read_ahead_s`` past the asked time, and reports older than
``max_gap_s`` before it are dropped, so memory holds a few minutes of the recording whatever
its size. Streaming needs the file in time order (as OpenSky's exports are); a report that
arrives after the replay has passed its time is counted in ``late_reports`` and left out.

Tracks are rebuilt from the kept reports only when new blocks were read: about every
``read_ahead_s`` of recording time (the build is vectorised, 0.13 s for 361,000 reports).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator

import numpy as np

from aamsim.realtraffic.reports import StateReports
from aamsim.realtraffic.tracks import TrackSet, build_tracks

#: Recordings larger than this once decompressed are streamed rather than read whole.
STREAM_ABOVE_BYTES = 16 * 1024 * 1024
#: How far past the replay's time a streamed recording is read [s of the recording's clock].
READ_AHEAD_S = 300.0


class TrackWindow:
    """Tracks of a stream of report blocks (see the module docstring).

    Args:
        blocks: blocks of reports, each sorted by time (a :class:`~aamsim.realtraffic.RecordingReader`).
        max_gap_s: a longer gap between two reports of an aircraft splits its track.
        read_ahead_s: how far past the asked time to read; ``inf`` reads everything at the first call.
    """

    def __init__(self, blocks: Iterable[StateReports], *, max_gap_s: float = 60.0,
                 read_ahead_s: float = READ_AHEAD_S):
        if not read_ahead_s > max_gap_s:
            raise ValueError(f"read_ahead_s ({read_ahead_s}) must be longer than max_gap_s ({max_gap_s})")
        self.max_gap_s, self.read_ahead_s = max_gap_s, read_ahead_s
        self._blocks: Iterator[StateReports] = iter(blocks)
        self._kept = StateReports.empty()
        self._fresh: list[StateReports] = []
        self._tracks: TrackSet | None = None
        self._read_until = -math.inf  # latest report time read so far
        self._dropped_before = -math.inf  # reports before this time were dropped (the replay passed them)
        self.eof = False
        self.first_time_s = math.nan  # the earliest report of the first block read (whole file: of all)
        self.late_reports = 0
        self.first_late_s = math.nan
        self.builds = 0

    @property
    def streaming(self) -> bool:
        return math.isfinite(self.read_ahead_s)

    def start(self) -> float:
        """Read the first block (the whole recording when not streaming); returns :attr:`first_time_s`."""
        if math.isnan(self.first_time_s) and not self.eof:
            self._read(-math.inf, first=True)
        return self.first_time_s

    def _read(self, t: float, first: bool = False) -> None:
        """Read blocks until the reports reach twice the read-ahead past ``t`` (or the end)."""
        target = t + 2.0 * self.read_ahead_s
        while not self.eof and (first or self._read_until < target):
            block = next(self._blocks, None)
            if block is None:
                self.eof = True
                break
            if len(block) == 0:
                continue
            if math.isnan(self.first_time_s):
                self.first_time_s = float(block.t_s.min()) if self.streaming else math.nan
            late = block.t_s < self._dropped_before
            if late.any():
                self.late_reports += int(late.sum())
                if math.isnan(self.first_late_s):
                    self.first_late_s = float(block.t_s[late][0])
                block = block.take(~late)
            self._fresh.append(block)
            self._read_until = max(self._read_until, float(block.t_s.max()) if len(block) else -math.inf)
            first = first and not self.streaming  # not streaming: read on to the end
        if not self.streaming and math.isnan(self.first_time_s):
            everything = [self._kept, *self._fresh]
            times = [float(b.t_s.min()) for b in everything if len(b)]
            self.first_time_s = min(times) if times else math.nan

    def tracks_at(self, t: float) -> TrackSet:
        """The tracks around recording time ``t`` [s since 1970]: every track flying at ``t`` is whole
        from ``max_gap_s`` before it to ``read_ahead_s`` after it (to its end when that is nearer)."""
        self.start()
        if not self.eof and self._read_until < t + self.read_ahead_s:
            self._read(t)
        if self._fresh or self._tracks is None:
            reports = StateReports.concat([self._kept, *self._fresh])
            self._fresh = []
            if self.streaming:
                # Interpolation at t and later needs a track's reports from the one before t on; a
                # report before that belongs to a gap longer than max_gap_s or to a finished track.
                cut = t - self.max_gap_s
                if len(reports) and float(reports.t_s.min()) < cut:
                    reports = reports.take(reports.t_s >= cut)
                self._dropped_before = max(self._dropped_before, cut)
            self._kept = reports
            self._tracks = build_tracks(reports, max_gap_s=self.max_gap_s)
            self.builds += 1
        return self._tracks

    def finished(self, t: float) -> bool:
        """True when no track is left to fly at or after ``t``: the whole recording is read and past."""
        if not self.eof or self._tracks is None or self._fresh:
            return False
        return bool(len(self._tracks) == 0 or np.all(self._tracks.t_last < t))

    @property
    def reports_kept(self) -> int:
        return len(self._kept) + sum(len(b) for b in self._fresh)
