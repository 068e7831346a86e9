"""Real air traffic replayed in a simulation: each recorded aircraft flies its track as a
non-cooperative intruder (``REPLAY`` command, ``aamsim run --overlay``; docs/real-traffic.md).

Every ``interval_s`` (1 s, the conflict-detection interval; every step when the step is
longer) the replay maps the simulation's time onto the recording's, asks its feed for the
tracks flying then, creates the aircraft that appear, deletes those whose track ended, and
puts every replayed aircraft at its interpolated state. Its velocity is the one that carries
it to its interpolated position at the next update, so the kernel's straight-line steps in
between follow the track (exactly within a stretch between two reports; cutting the corner
by at most a quarter of the velocity change times the interval where a report falls inside).

Replayed aircraft are created ``noncooperative``: conflict detection and the separation events
see them, use cases observe them as intruders and never make them agents, and every intent
(SPD, ALT, HDG, advisories, ...) refuses them. Only DEL removes one; it then stays away.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np

from aamsim.errors import CommandError
from aamsim.realtraffic.readers import DEFAULT_CHUNK_ROWS, RecordingReader, decoded_size_above
from aamsim.realtraffic.reports import RecordingError, SkipLog
from aamsim.realtraffic.tracks import TrackSet, TrackStates
from aamsim.realtraffic.window import READ_AHEAD_S, STREAM_ABOVE_BYTES, TrackWindow
from aamsim.units import R_EARTH, UnitParseError, parse_time

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

#: Aircraft type of replayed aircraft (the kernel flies them without a performance envelope).
REPLAY_TYPE = "REAL"
#: Updates between which the replay puts its aircraft on their tracks [s of simulation time].
UPDATE_INTERVAL_S = 1.0
#: Skipped rows reported one by one per replay; the rest are counted in the end note.
REPORTED_SKIPS = 20

BBox = tuple[float, float, float, float]


class TrackFeed(Protocol):
    """Where a replay's tracks come from: a recording (:class:`TrackWindow`) or a live poller."""

    def start(self) -> float:
        """The recording time of the first report (s since 1970), read now if need be (NaN: none)."""

    def tracks_at(self, t: float) -> TrackSet:
        """Tracks holding every aircraft flying at recording time ``t``."""

    def finished(self, t: float) -> bool:
        """True when nothing is left to fly at or after ``t``."""


@dataclass(frozen=True)
class Alignment:
    """Which recording time plays at which scenario time.

    ``recording_s`` None: the recording's first report plays at ``scenario_s`` (the default, 0).
    Otherwise recording time ``recording_s`` (s since 1970 UTC) plays at ``scenario_s``.
    """

    scenario_s: float = 0.0
    recording_s: float | None = None

    @staticmethod
    def parse(text: str) -> Alignment:
        """``""`` (first report at 0), ``[-][[HH:]MM:]SS`` (the first report at that scenario time;
        negative: start that far into the recording), or ``@T`` with T a UTC time (ISO 8601, or s
        since 1970): the recording's moment T plays at scenario time 0."""
        text = text.strip()
        if not text:
            return Alignment()
        if text.startswith("@"):
            return Alignment(0.0, parse_utc(text[1:]))
        sign = -1.0 if text.startswith("-") else 1.0
        try:
            return Alignment(sign * parse_time(text.lstrip("+-")))
        except UnitParseError:
            raise CommandError(f'"{text}": a time offset is [-][[HH:]MM:]SS (the scenario time of the recording\'s '
                               "first report) or @UTC-TIME (the recording's moment played at time 0)") from None


def parse_utc(text: str) -> float:
    """A UTC time as s since 1970: a number, or ISO 8601 (``2019-03-14T09:30:00``, ``Z`` or offset allowed)."""
    try:
        return float(text)
    except ValueError:
        pass
    try:
        moment = datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        raise CommandError(f'"{text}" is not a UTC time (ISO 8601 or seconds since 1970)') from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=UTC)
    return moment.timestamp()


def parse_area(values: list[float]) -> BBox | None:
    """``[lat0, lon0, lat1, lon1]`` (any two corners) as (lat_min, lon_min, lat_max, lon_max); [] is None."""
    if not values:
        return None
    if len(values) != 4:
        raise CommandError(f"an area is 4 numbers LAT0,LON0,LAT1,LON1, not {len(values)}")
    lat0, lon0, lat1, lon1 = values
    if not all(math.isfinite(v) for v in values) or not (-90 <= lat0 <= 90 and -90 <= lat1 <= 90):
        raise CommandError(f"area {values}: latitudes must be within -90..90")
    return (min(lat0, lat1), lon0, max(lat0, lat1), lon1)


@dataclass
class ReplayedFlight:
    """One replayed track: the simulation's callsign and what the recording says."""

    callsign: str
    icao24: str
    recorded_callsign: str
    created_s: float
    deleted_s: float = math.nan
    removed_by_user: bool = False


class RecordingFeed(TrackWindow):
    """A recording file as a :class:`TrackFeed`: read whole when small, else streamed."""

    def __init__(self, path: Path, *, area: BBox | None = None, max_gap_s: float = 60.0,
                 stream_above_bytes: int = STREAM_ABOVE_BYTES, chunk_rows: int | None = None):
        streaming = decoded_size_above(path, stream_above_bytes)
        self.reader = RecordingReader(path, bbox=area, chunk_rows=chunk_rows or DEFAULT_CHUNK_ROWS)
        super().__init__(self.reader, max_gap_s=max_gap_s, read_ahead_s=READ_AHEAD_S if streaming else math.inf)
        self.path = path

    @property
    def skipped(self) -> SkipLog:
        return self.reader.skipped


class Replay:
    """One overlay of real traffic on a simulation (see the module docstring)."""

    def __init__(self, feed: TrackFeed, *, name: str, prefix: str = "RT", alignment: Alignment = Alignment(),
                 interval_s: float = UPDATE_INTERVAL_S):
        if not interval_s > 0:
            raise ValueError(f"interval_s must be positive, not {interval_s}")
        self.feed, self.name, self.prefix, self.alignment, self.interval_s = feed, name, prefix, alignment, interval_s
        self.t0_s = math.nan  # recording time played at alignment.scenario_s
        self.flights: list[ReplayedFlight] = []
        self._flying: dict[str, int] = {}  # icao24 -> index into flights
        self._by_callsign: dict[str, int] = {}
        self._appearances: dict[str, int] = {}
        self._removed: set[str] = set()  # icao24s a user deleted: not replayed again
        self._deleting = False
        self._skips_reported = 0
        self.updates = 0

    # ------------------------------------------------------------ lifecycle
    def attach(self, sim: CommandContext) -> None:
        """Start replaying from the simulation's current time (hooks, and an immediate first update)."""
        try:
            first = self.feed.start()
        except RecordingError as err:
            raise CommandError(str(err)) from None
        self.t0_s = self.alignment.recording_s if self.alignment.recording_s is not None else first
        if math.isnan(self.t0_s):
            sim.report("warning", f"REPLAY {self.name}: no airborne reports to replay", sim.current_source)
        sim.hooks.pre_step.add(self.update, interval_s=lambda: self.interval_s, name=f"replay:{self.prefix}",
                               priority=5, start_us=0)
        sim.hooks.deleted.add(self._on_deleted, name=f"replay:{self.prefix}.deleted")
        sim.pending_work.append(lambda: self.pending(sim.simt))
        replays = sim.features.get(Replays)
        if replays is None:
            replays = sim.features.add(Replays())
        if not replays and sim.run_outputs.collecting:  # aamsim run: its run directory gets the list
            sim.run_outputs.add(write_run_outputs)
        replays.append(self)
        sim.report("note", self.describe(), sim.current_source)

    def describe(self) -> str:
        start = "nothing" if math.isnan(self.t0_s) else _utc(self.t0_s)
        return (f"REPLAY {self.name}: recording time {start} plays at scenario time {self.alignment.scenario_s:g} s; "
                f"aircraft named {self.prefix}<icao24>, updated every {self.interval_s:g} s")

    def recording_time(self, simt: float) -> float:
        """The recording's time [s since 1970] at scenario time ``simt``."""
        return self.t0_s + (simt - self.alignment.scenario_s)

    def pending(self, simt: float) -> bool:
        """True while tracks are flying or to come (keeps an open-ended run going)."""
        return bool(self._flying) or not (math.isnan(self.t0_s) or self.feed.finished(self.recording_time(simt)))

    # --------------------------------------------------------------- update
    def update(self, sim: CommandContext) -> None:
        """Create, delete and place the replayed aircraft for the current time (the pre-step hook)."""
        if math.isnan(self.t0_s):
            return
        t = self.recording_time(sim.simt)
        live_time = getattr(self.feed, "live_time", None)
        if live_time is not None:
            t = live_time(t)
        try:
            tracks = self.feed.tracks_at(t)
        except RecordingError as err:
            sim.report("error", f"REPLAY {self.name}: {err}; the replay stops")
            self.t0_s = math.nan
            self._end_all(sim)
            return
        self._report_skips(sim)
        now = tracks.states_at(t)
        icao = tracks.icao24[now.index]
        keep = ~np.isin(icao, list(self._removed)) if self._removed else np.ones(len(icao), dtype=bool)
        active = set(icao[keep].tolist())
        gone = [x for x in self._flying if x not in active]
        self._delete(sim, gone)
        callsigns = []
        placed = np.flatnonzero(keep)
        ok = np.ones(len(placed), dtype=bool)
        for m, k in enumerate(placed.tolist()):
            code = str(icao[k])
            if code not in self._flying and not self._create(sim, tracks, now, k, code):
                ok[m] = False
                continue
            callsigns.append(self.flights[self._flying[code]].callsign)
        placed = placed[ok]
        if len(placed):
            horizon = max(self.interval_s, sim.dt)
            north, east, up = self._velocity(tracks, now, placed, t, horizon)
            sim.set_replay_state(callsigns, now.lat[placed], now.lon[placed], now.alt_m[placed], north, east, up)
        self.updates += 1

    @staticmethod
    def _velocity(tracks: TrackSet, now: TrackStates, placed: np.ndarray, t: float,
                  horizon: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """North, east, up [m/s] that carry each aircraft to its interpolated position ``horizon`` later
        (the kernel's Euler step inverted); its recorded motion where its track ends before then."""
        rad = math.radians(1.0)
        trk = np.radians(now.trk_deg[placed])
        north = now.gs_mps[placed] * np.cos(trk)
        east = now.gs_mps[placed] * np.sin(trk)
        up = now.vs_mps[placed].copy()
        ahead = tracks.states_at(t + horizon)
        where = np.searchsorted(ahead.index, now.index[placed])
        where = np.minimum(where, max(len(ahead.index) - 1, 0))
        has = (ahead.index[where] == now.index[placed]) if len(ahead.index) else np.zeros(len(placed), dtype=bool)
        if has.any():
            rows = placed[has]
            later = where[has]
            lat0 = now.lat[rows]
            north[has] = (ahead.lat[later] - lat0) * rad * R_EARTH / horizon
            dlon = np.mod(ahead.lon[later] - now.lon[rows] + 180.0, 360.0) - 180.0
            east[has] = dlon * rad * R_EARTH * np.cos(np.radians(lat0)) / horizon
            up[has] = (ahead.alt_m[later] - now.alt_m[rows]) / horizon
        return north, east, up

    def _create(self, sim: CommandContext, tracks: TrackSet, now: TrackStates, k: int, code: str) -> bool:
        count = self._appearances.get(code, 0) + 1
        callsign = f"{self.prefix}{code.upper()}" + (f"-{count}" if count > 1 else "")
        try:
            sim.create_aircraft(callsign, REPLAY_TYPE, float(now.lat[k]), float(now.lon[k]),
                                float(now.trk_deg[k]), float(now.alt_m[k]), noncooperative=True)
        except CommandError as err:
            sim.report("warning", f"REPLAY {self.name}: track {code} not replayed: {err}")
            self._removed.add(code)
            return False
        self._appearances[code] = count
        track = int(now.index[k])
        self._flying[code] = len(self.flights)
        self._by_callsign[callsign] = len(self.flights)
        self.flights.append(ReplayedFlight(callsign, code, str(tracks.callsign[track]), sim.simt))
        return True

    def _delete(self, sim: CommandContext, codes: list[str]) -> None:
        if not codes:
            return
        names = [self.flights[self._flying.pop(code)].callsign for code in codes]
        self._deleting = True
        try:
            for name in names:
                sim.delete_aircraft(sim.slot(name), arrived=False)
        finally:
            self._deleting = False
        for name in names:
            self.flights[self._by_callsign[name]].deleted_s = sim.simt

    def _end_all(self, sim: CommandContext) -> None:
        self._delete(sim, list(self._flying))

    def _on_deleted(self, sim: CommandContext, slot: int, record: object) -> None:
        if self._deleting:
            return
        callsign = sim.view.callsign(slot)
        index = self._by_callsign.get(callsign)
        if index is None or self.flights[index].icao24 not in self._flying:
            return
        flight = self.flights[index]
        del self._flying[flight.icao24]
        flight.deleted_s, flight.removed_by_user = sim.simt, True
        self._removed.add(flight.icao24)

    def _report_skips(self, sim: CommandContext) -> None:
        skipped: SkipLog | None = getattr(self.feed, "skipped", None)
        if skipped is None:
            return
        rows = skipped.rows[self._skips_reported:REPORTED_SKIPS]
        for row in rows:
            sim.report("warning", f"REPLAY: {row} (row skipped)")
        self._skips_reported += len(rows)

    def summary(self) -> dict[str, object]:
        """What was replayed (for summary.json)."""
        skipped: SkipLog | None = getattr(self.feed, "skipped", None)
        out: dict[str, object] = {
            "source": self.name, "prefix": self.prefix, "recording_start_utc": _utc(self.t0_s),
            "scenario_time_of_start_s": self.alignment.scenario_s, "aircraft_replayed": len(self.flights),
            "removed_by_user": sum(f.removed_by_user for f in self.flights),
        }
        if skipped is not None:
            out["rows_skipped"] = skipped.total
            out["rows_skipped_by_reason"] = dict(skipped.counts)
        late = getattr(self.feed, "late_reports", 0)
        if late:
            out["reports_out_of_time_order"] = late
        return out


REAL_TRAFFIC_COLUMNS = ["id", "icao24", "callsign", "source", "created_s", "deleted_s", "removed_by_user"]


def write_run_outputs(sim: CommandContext, out_dir: Path, summary: dict[str, object]) -> None:
    """``real_traffic.csv`` (one row per replayed track) and the replays' part of summary.json."""
    replays = replays_of(sim)
    summary["real_traffic"] = [r.summary() for r in replays]
    for replay in replays:
        skipped: SkipLog | None = getattr(replay.feed, "skipped", None)
        if skipped is not None and skipped.total > replay._skips_reported:
            sim.report("warning", f"REPLAY {replay.name}: {skipped.total} rows skipped in all:\n{skipped.summary()}")
    with open(out_dir / "real_traffic.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(REAL_TRAFFIC_COLUMNS)
        for replay in replays:
            for f in replay.flights:
                deleted = "" if math.isnan(f.deleted_s) else f"{f.deleted_s:.2f}"
                writer.writerow([f.callsign, f.icao24, f.recorded_callsign, replay.name, f"{f.created_s:.2f}",
                                 deleted, "true" if f.removed_by_user else "false"])


def _utc(t: float) -> str:
    if not math.isfinite(t):
        return ""
    return datetime.fromtimestamp(t, tz=UTC).isoformat().replace("+00:00", "Z")


class Replays(list[Replay]):
    """The replays attached to a simulation, in the order they started (its feature state)."""


def replays_of(sim: CommandContext) -> list[Replay]:
    """The replays attached to a simulation, in the order they started."""
    replays = sim.features.get(Replays)
    return [] if replays is None else replays


def next_prefix(sim: CommandContext) -> str:
    """``RT`` for the first replay of a simulation, ``R2``, ``R3``... after it (callsigns stay unique)."""
    count = len(replays_of(sim))
    return "RT" if count == 0 else f"R{count + 1}"


def start_recording(sim: CommandContext, path_text: str, offset: str = "", area: BBox | None = None,
                    *, max_gap_s: float = 60.0, interval_s: float = UPDATE_INTERVAL_S,
                    name: str | None = None) -> Replay:
    """Overlay a recording file from now on (what ``REPLAY`` and ``--overlay FILE`` do)."""
    path = sim.find_file(path_text)
    if path is None:
        raise CommandError(f"REPLAY: recording not found: {path_text}")
    try:
        feed = RecordingFeed(path, area=area, max_gap_s=max_gap_s)
    except RecordingError as err:
        raise CommandError(str(err)) from None
    replay = Replay(feed, name=name or path_text, prefix=next_prefix(sim), alignment=Alignment.parse(offset),
                    interval_s=interval_s)
    replay.attach(sim)
    return replay
