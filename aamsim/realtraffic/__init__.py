"""Real air traffic (OpenSky Network recordings, traffic-library exports) as SI state reports and tracks.

Contract: docs/real-traffic.md.
"""

from aamsim.realtraffic.columns import ColumnPlan, plan_columns
from aamsim.realtraffic.readers import RecordingReader, detect_format, read_reports
from aamsim.realtraffic.reports import REPORT_FIELDS, RecordingError, SkipLog, SkippedRow, StateReports
from aamsim.realtraffic.tracks import BuildSummary, Track, TrackSet, TrackStates, build_tracks

__all__ = [
    "REPORT_FIELDS", "BuildSummary", "ColumnPlan", "RecordingError", "RecordingReader", "SkipLog", "SkippedRow",
    "StateReports", "Track", "TrackSet", "TrackStates", "build_tracks", "detect_format", "plan_columns",
    "read_reports",
]
