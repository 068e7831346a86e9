"""Pictures of the traffic: one :class:`TrafficFrame` per instant, one :class:`MapLayout` per scenario.

A frame holds what a viewer draws at one sim time: the aircraft (position,
altitude, track, airspeed), each one's state (normal, inside a LoWC or NMAC
volume, holding below the holding speed), the separation events that began
since the previous frame (they flash where they happened) and the running
totals of the side panel. It comes from a live simulation
(:func:`frame_from_sim`, through the simulator API and the conflict service)
or from a run directory (:class:`RunReplay`, from ``trajectories.csv``,
``conflicts.csv``, ``flights.csv`` and ``summary.json``). The web viewer and
the matplotlib renderer draw the same frames, so a replay, a live run and an
environment's ``render()`` look alike.

The map (:class:`MapLayout`) is read from the scenario text: user waypoints
(``DEFWPT``) named as an origin or destination are vertiports, and the legs of
every route (``ORIG`` -> ``ADDWPT``... -> ``DEST``) are drawn once each.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.settings import SimSettings
from aamsim.units import MAX_CALLSIGN_CHARS, R_EARTH

if TYPE_CHECKING:
    from aamsim.simulation import Simulation

STATUS_NORMAL, STATUS_LOWC, STATUS_NMAC, STATUS_HOLDING = 0, 1, 2, 3
STATUS_NAMES = ("normal", "lowc", "nmac", "holding")
# Blue for normal traffic, orange inside the LoWC volume, red inside the NMAC volume, purple when holding
# (colour-blind safe against each other and against the dark map).
STATUS_COLOURS = ("#4fa3e0", "#f39c12", "#e8253a", "#b07cdb")

DEFAULT_HOLD_SPEED_MPS = SimSettings.hold_speed_mps  # the default holding-speed threshold (5 kt)
DEFAULT_AIRBORNE_ALT_M = SimSettings.airborne_alt_m  # the default: above 10 ft an aircraft is airborne


def airborne_status(alt: np.ndarray, tas: np.ndarray, hold_speed_mps: float,
                    airborne_alt_m: float = DEFAULT_AIRBORNE_ALT_M) -> tuple[np.ndarray, np.ndarray]:
    """Per aircraft: airborne (above ``airborne_alt_m``), and the status normal or holding (airborne below
    the holding speed, as the holding metric counts it: an aircraft on the ground is not holding)."""
    airborne = np.asarray(alt) > airborne_alt_m
    holding = airborne & (np.asarray(tas) < hold_speed_mps)
    return airborne, np.where(holding, STATUS_HOLDING, STATUS_NORMAL).astype(np.int8)


class ReplayError(ValueError):
    """A run directory that cannot be replayed; the message names the file."""


@dataclass(frozen=True)
class ConflictEvent:
    """An NMAC or LoWC that began at ``t`` between aircraft ``ids``, placed at their mid-point."""

    kind: str  # "nmac" | "lowc"
    t: float
    ids: tuple[str, str]
    lat: float
    lon: float


@dataclass(frozen=True)
class TrafficFrame:
    """The traffic at ``simt``: one entry per aircraft in every array (SI units, degrees)."""

    simt: float
    ids: tuple[str, ...]
    lat: np.ndarray
    lon: np.ndarray
    alt: np.ndarray  # m
    trk: np.ndarray  # deg
    tas: np.ndarray  # m/s
    status: np.ndarray  # int8, STATUS_*
    events: tuple[ConflictEvent, ...] = ()
    metrics: dict[str, float] = field(default_factory=dict)
    advisories: dict[str, str] = field(default_factory=dict)  # callsign -> latest advisory (live runs)

    def __len__(self) -> int:
        return len(self.ids)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict, positions rounded to about 1 m (what the browser page reads).

        A value that is not finite (NaN or inf in a run's CSV) is ``null``: JSON has no NaN, and
        a ``NaN`` token made the page's parser, and the WebSocket stream, stop.
        """
        return {
            "simt": _finite(self.simt, 3),
            "ids": list(self.ids),
            "lat": _finite_list(self.lat, 5),
            "lon": _finite_list(self.lon, 5),
            "alt": _finite_list(self.alt, 1),
            "trk": _finite_list(self.trk, 1),
            "tas": _finite_list(self.tas, 1),
            "status": self.status.astype(int).tolist(),
            "events": [{"kind": e.kind, "t": _finite(e.t, 2), "ids": list(e.ids), "lat": _finite(e.lat, 5),
                        "lon": _finite(e.lon, 5)} for e in self.events],
            "metrics": {k: (_finite(v, 3) if isinstance(v, float) else v) for k, v in self.metrics.items()},
            "advisories": self.advisories,
        }


def _finite(value: float, decimals: int) -> float | None:
    """``value`` rounded, or None when it is not finite (JSON has no NaN or infinity)."""
    value = float(value)
    return round(value, decimals) if math.isfinite(value) else None


def _finite_list(values: np.ndarray, decimals: int) -> list[float | None]:
    rounded = np.round(np.asarray(values, dtype=np.float64), decimals)
    finite = np.isfinite(rounded)
    if finite.all():
        return rounded.tolist()  # type: ignore[no-any-return]
    return [v if ok else None for v, ok in zip(rounded.tolist(), finite.tolist())]


@dataclass(frozen=True)
class MapLayout:
    """The static map: vertiports, route legs, an optional outline, and the bounds to show."""

    vertiports: tuple[tuple[str, float, float], ...]  # (name, lat, lon)
    routes: tuple[np.ndarray, ...]  # polylines, each (k, 2) of (lat, lon)
    outline: tuple[np.ndarray, ...]  # coastline/borough polylines (k, 2); none shipped yet
    bounds: tuple[float, float, float, float]  # lat_min, lat_max, lon_min, lon_max

    def to_json(self) -> dict[str, Any]:
        return {
            "vertiports": [[n, round(a, 6), round(o, 6)] for n, a, o in self.vertiports],
            "routes": [np.round(r, 6).tolist() for r in self.routes],
            "outline": [np.round(r, 6).tolist() for r in self.outline],
            "bounds": [round(x, 6) for x in self.bounds],
        }


# ---------------------------------------------------------------- the map, from the scenario text
_SPLIT = re.compile(r"[\s,]+")


def _number(text: str, limit: float = 180.0) -> float | None:
    """A latitude or longitude of the scenario text [deg], or None (not a number, not on the earth)."""
    try:
        x = float(text)
    except ValueError:
        return None
    return x if abs(x) <= limit else None  # NaN fails the comparison too


def layout_from_scenario(text: str, extra_lat: np.ndarray | None = None,
                         extra_lon: np.ndarray | None = None, coastline: bool = True) -> MapLayout:
    """The map of a scenario: vertiports and route legs (see the module docstring).

    ``extra_lat``/``extra_lon`` (flown positions) widen the bounds beyond the network;
    ``coastline``: BlueSky's coastlines within the bounds, when BlueSky is installed
    (:mod:`aamsim.viewer.coastline`).
    """
    points: dict[str, tuple[float, float]] = {}
    ends: set[str] = set()
    routes: dict[str, list[tuple[float, float]]] = {}
    dests: dict[str, tuple[float, float]] = {}
    created: list[tuple[float, float]] = []  # where aircraft appear: on the map even when they fly no route
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if ">" in line:
            line = line.split(">", 1)[1]
        words = [w for w in _SPLIT.split(line.strip()) if w]
        if len(words) < 3:
            continue
        cmd, acid = words[0].upper(), words[1].upper()
        if cmd == "DEFWPT" and len(words) >= 4:
            lat, lon = _number(words[2]), _number(words[3])
            if lat is not None and lon is not None:
                points[acid] = (lat, lon)
        elif cmd == "CRE" and len(words) >= 5:
            lat, lon = _number(words[3]), _number(words[4])
            if lat is not None and lon is not None:
                routes[acid] = [(lat, lon)]
                dests.pop(acid, None)
                created.append((lat, lon))
        elif cmd in ("ORIG", "DEST", "ADDWPT"):
            name = words[2].upper()
            pos = points.get(name)
            if pos is None and len(words) >= 4:
                lat, lon = _number(words[2]), _number(words[3])
                pos = (lat, lon) if lat is not None and lon is not None else None
            if pos is None:
                continue
            if cmd == "ADDWPT":
                routes.setdefault(acid, []).append(pos)
            else:
                ends.add(name)
                if cmd == "DEST":
                    dests[acid] = pos
    legs: set[tuple[float, float, float, float]] = set()
    for acid, pts in routes.items():
        if acid in dests:
            pts = [*pts, dests[acid]]
        for (a1, o1), (a2, o2) in itertools.pairwise(pts):
            if (a1, o1) != (a2, o2):
                legs.add((a1, o1, a2, o2) if (a1, o1) < (a2, o2) else (a2, o2, a1, o1))
    vertiports = tuple(sorted((n, *points[n]) for n in ends if n in points))
    route_lines = tuple(np.array([[a1, o1], [a2, o2]]) for a1, o1, a2, o2 in sorted(legs))
    lats = [v[1] for v in vertiports] + [x for leg in legs for x in (leg[0], leg[2])]
    lons = [v[2] for v in vertiports] + [x for leg in legs for x in (leg[1], leg[3])]
    lats += [p[0] for p in created]
    lons += [p[1] for p in created]
    if extra_lat is not None and extra_lon is not None and len(extra_lat):
        # Only positions on the earth widen the map: NaN or 1e300 in a CSV made the bounds (and /api/meta) NaN.
        on_earth = (np.abs(extra_lat) <= 90.0) & (np.abs(extra_lon) <= 180.0)
        if on_earth.any():
            lats += [float(np.min(extra_lat[on_earth])), float(np.max(extra_lat[on_earth]))]
            lons += [float(np.min(extra_lon[on_earth])), float(np.max(extra_lon[on_earth]))]
    bounds = padded_bounds(lats, lons)
    outline: tuple[np.ndarray, ...] = ()
    if coastline:
        from aamsim.viewer.coastline import coastlines

        outline = coastlines(bounds)
    return MapLayout(vertiports, route_lines, outline, bounds)


def padded_bounds(lats: list[float], lons: list[float]) -> tuple[float, float, float, float]:
    if not lats:
        return (-0.05, 0.05, -0.05, 0.05)
    lat0, lat1, lon0, lon1 = min(lats), max(lats), min(lons), max(lons)
    pad_lat = max(0.05 * (lat1 - lat0), 0.005)
    pad_lon = max(0.05 * (lon1 - lon0), 0.005)
    return (lat0 - pad_lat, lat1 + pad_lat, lon0 - pad_lon, lon1 + pad_lon)


# ---------------------------------------------------------------- live: from a simulation
def layout_from_sim(sim: Simulation, scenario_text: str | None = None) -> MapLayout:
    """The map of a live simulation: its scenario's network, widened to the aircraft flying now."""
    view = sim.view
    return layout_from_scenario(scenario_text or "", np.asarray(view.lat), np.asarray(view.lon))


def frame_from_sim(sim: Simulation, events_since: float | None = None) -> TrafficFrame:
    """The traffic of a live simulation now, with the events that began after ``events_since``."""
    view = sim.view
    ids = tuple(view.ids)
    lat, lon, alt = (np.array(x, dtype=np.float64) for x in (view.lat, view.lon, view.alt))
    trk, tas = np.array(view.trk, dtype=np.float64), np.array(view.tas, dtype=np.float64)
    airborne, status = airborne_status(alt, tas, sim.settings.hold_speed_mps, sim.settings.airborne_alt_m)
    service = sim.services.conflicts
    slot = {a: i for i, a in enumerate(ids)}
    for volume, code in (("lowc", STATUS_LOWC), ("nmac", STATUS_NMAC)):
        for acid in service.in_volume_now(volume):
            i = slot.get(acid)
            if i is not None:
                status[i] = code
    events: list[ConflictEvent] = []
    if events_since is not None:
        for volume in ("nmac", "lowc"):
            for ev in service.started_since(volume, events_since):
                pos = [(lat[slot[a]], lon[slot[a]]) for a in (ev.ac1, ev.ac2) if a in slot]
                if not pos:
                    continue
                events.append(ConflictEvent(volume, ev.start_s, (ev.ac1, ev.ac2),
                                            float(np.mean([p[0] for p in pos])), float(np.mean([p[1] for p in pos]))))
    metrics: dict[str, float] = {
        "airborne": int(np.count_nonzero(airborne)),
        "nmac": service.count("nmac"),
        "lowc": service.count("lowc"),
        "completed": sum(1 for f in sim.flight_log if f.arrived),
        "holding": int(np.count_nonzero(status == STATUS_HOLDING)),
    }
    flights = (view.flight(i) for i in range(len(ids)))
    advisories = {a: f.last_advisory for a, f in zip(ids, flights) if f.last_advisory}
    return TrafficFrame(sim.simt, ids, lat, lon, alt, trk, tas, status, tuple(events), metrics, advisories)


# ---------------------------------------------------------------- replay: from a run directory
_TRAJ_COLUMNS = ("simt", "lat", "lon", "alt_m", "tas_mps", "gs_mps", "trk_deg")
MAX_SUMMARY_BYTES = 1 << 20


def _read_ids(path: Path, column: int, warnings: list[str]) -> tuple[np.ndarray, np.ndarray, int]:
    """The aircraft ids of ``trajectories.csv``: the sorted distinct ids, each row's code, the row count.

    One pass in Python with a dictionary, never a fixed-width array of every row's id: NumPy sizes
    such an array by the longest id, so one 20,000-character id in a 1.9 MB file made ``aamsim view``
    take 8.7 GB. An id longer than a callsign can be (:data:`aamsim.units.MAX_CALLSIGN_CHARS`) is an
    error naming its line. A last line without its line end (a run killed mid-write, a full disk) is
    left out with a warning: the rows are those that end in a newline.
    """
    index: dict[str, int] = {}
    codes: list[int] = []
    with open(path, encoding="utf-8", errors="replace", newline="") as fh:
        fh.readline()
        for lineno, line in enumerate(fh, start=2):
            if not line.endswith("\n"):
                warnings.append(f"{path}: line {lineno}: cut short (no line end: the run stopped while writing "
                                "it?); left out")
                break
            if not line.strip():
                continue  # a blank line (loadtxt skips those too)
            fields = line.split(",", column + 1)
            if len(fields) <= column:
                raise ReplayError(f"{path}: line {lineno}: no id (column {column + 1})")
            name = fields[column]
            code = index.get(name)
            if code is None:
                if len(name) > MAX_CALLSIGN_CHARS:
                    raise ReplayError(f"{path}: line {lineno}: an id of {len(name):,} characters; a callsign has "
                                      f"at most {MAX_CALLSIGN_CHARS}")
                code = index[name] = len(index)
            codes.append(code)
    names = sorted(index)
    recode = np.empty(len(index), dtype=np.int64)
    recode[[index[n] for n in names]] = np.arange(len(names))
    return (np.array(names, dtype=f"U{max(1, max(map(len, names), default=1))}"),
            recode[np.asarray(codes, dtype=np.int64)], len(codes))


class RunReplay:
    """A run directory, indexed once so that any instant is drawn in milliseconds.

    ``trajectories.csv`` is required (a run with ``--log-period 0`` has none);
    ``conflicts.csv``, ``flights.csv``, ``summary.json`` and ``scenario.scn``
    add states, totals and the map when present. Samples are sorted by time,
    so a frame is one block of rows found by bisection, dead-reckoned from
    the sample to the frame's time along the track at the ground speed.
    """

    def __init__(self, run_dir: str | Path) -> None:
        self.run_dir = Path(run_dir)
        if not self.run_dir.is_dir():
            raise ReplayError(f"{self.run_dir}: not a directory (expected an aamsim run directory)")
        traj = self.run_dir / "trajectories.csv"
        if not traj.is_file():
            raise ReplayError(f"{traj}: missing; nothing to replay (the run was made with --log-period 0, "
                              "or this is not a run directory)")
        self.summary: dict[str, Any] = self._read_summary()
        self._read_trajectories(traj)
        self._read_conflicts(self.run_dir / "conflicts.csv")
        self._read_flights(self.run_dir / "flights.csv")
        hold = self.summary.get("operational", {}).get("holding_speed_threshold_mps")  # a dict: _read_summary
        self.hold_speed_mps = float(hold) if isinstance(hold, (int, float)) else DEFAULT_HOLD_SPEED_MPS
        self._layout: MapLayout | None = None

    # ------------------------------------------------------------ reading
    def _read_summary(self) -> dict[str, Any]:
        """``summary.json``, as far as the viewer uses it: the scenario's name and two groups of numbers.

        Whatever else the file holds is left out: a ``safety`` that is a list, not an object, used to end
        ``aamsim view`` with an AttributeError, and NaN in it made ``/api/meta`` invalid JSON.
        """
        path = self.run_dir / "summary.json"
        if not path.is_file():
            return {}
        if path.stat().st_size > MAX_SUMMARY_BYTES:
            raise ReplayError(f"{path}: {path.stat().st_size:,} bytes; a run's summary is a few kB "
                              f"(at most {MAX_SUMMARY_BYTES:,} read)")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ReplayError(f"{path}: not valid JSON ({exc})") from None
        except RecursionError:
            raise ReplayError(f"{path}: not a run summary (JSON nested too deep)") from None
        if not isinstance(data, dict):
            raise ReplayError(f"{path}: expected a JSON object")
        summary: dict[str, Any] = {}
        if isinstance(data.get("scenario"), str):
            summary["scenario"] = data["scenario"][:200]
        for group in ("safety", "operational"):
            values = data.get(group)
            if isinstance(values, dict):
                summary[group] = {str(k)[:100]: (v if not isinstance(v, float) or math.isfinite(v) else None)
                                  for k, v in values.items() if isinstance(v, (int, float, str, type(None)))}
        return summary

    def _read_trajectories(self, path: Path) -> None:
        with open(path, encoding="utf-8", errors="replace") as fh:
            header = fh.readline().strip().split(",")
            empty = not fh.readline().strip()  # a run in which no aircraft ever flew
        missing = [c for c in ("id", *_TRAJ_COLUMNS) if c not in header]
        if missing:
            raise ReplayError(f"{path}: line 1: missing column(s) {', '.join(missing)} "
                              f"(an aamsim trajectories.csv has id,simt,lat,lon,alt_m,tas_mps,...,trk_deg)")
        cols = [header.index(c) for c in _TRAJ_COLUMNS]
        self.warnings: list[str] = []
        if empty:
            data, codes = np.zeros((0, len(cols))), np.zeros(0, dtype=np.int64)
            self.callsigns = np.zeros(0, dtype=str)
        else:
            data, codes = self._load(path, header, cols)
        self._index(data, codes)

    def _load(self, path: Path, header: list[str], cols: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """The numbers of every row, and each row's aircraft as a code into :attr:`callsigns`."""
        names, codes, rows = _read_ids(path, header.index("id"), self.warnings)
        try:
            data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, dtype=np.float64, ndmin=2,
                              comments=None, max_rows=rows)
        except ValueError as exc:
            raise ReplayError(f"{path}: {exc}") from None
        if len(data) != rows:
            raise ReplayError(f"{path}: {rows} rows have an id but {len(data)} have numbers")
        if len(data) and not np.isfinite(data[:, 0]).all():
            bad = int(np.flatnonzero(~np.isfinite(data[:, 0]))[0]) + 2
            raise ReplayError(f"{path}: line {bad}: simt is not a number")
        self.callsigns = names
        return data, codes

    def _index(self, data: np.ndarray, codes: np.ndarray) -> None:
        order = np.argsort(data[:, 0], kind="stable")
        data, self._code = data[order], codes[order]
        self._t, self._lat, self._lon, self._alt, self._tas, self._gs, self._trk = (
            np.ascontiguousarray(data[:, k]) for k in range(7))
        self.times, self._block = np.unique(self._t, return_index=True)
        self._block = np.append(self._block, len(self._t))
        self.t_start = float(self.times[0]) if len(self.times) else 0.0
        self.t_end = float(self.times[-1]) if len(self.times) else 0.0
        self.sample_period_s = float(np.median(np.diff(self.times))) if len(self.times) > 1 else 1.0

    def _read_conflicts(self, path: Path) -> None:
        self._ev_kind = np.zeros(0, dtype=np.int8)
        self._ev_a = self._ev_b = np.zeros(0, dtype=np.int64)
        self._ev_start = self._ev_end = self._ev_lat = self._ev_lon = np.zeros(0)
        if not path.is_file():
            return
        import csv

        kinds, a, b, start, end, lat, lon = [], [], [], [], [], [], []
        index = {c: i for i, c in enumerate(self.callsigns.tolist())}
        with open(path, newline="", encoding="utf-8", errors="replace") as fh:
            reader = csv.DictReader(fh)
            need = ("volume", "ac1", "ac2", "start_s", "end_s", "lat1", "lon1", "lat2", "lon2")
            missing = [c for c in need if c not in (reader.fieldnames or [])]
            if missing:
                raise ReplayError(f"{path}: line 1: missing column(s) {', '.join(missing)}")
            for lineno, row in enumerate(reader, start=2):
                volume = row["volume"]
                if volume not in ("nmac", "lowc"):
                    continue  # other volumes (user-defined) are not drawn
                try:
                    s, e = float(row["start_s"]), float(row["end_s"] or "nan")
                    la = (float(row["lat1"]) + float(row["lat2"])) / 2
                    lo = (float(row["lon1"]) + float(row["lon2"])) / 2
                except ValueError as exc:
                    raise ReplayError(f"{path}: line {lineno}: {exc}") from None
                kinds.append(STATUS_NMAC if volume == "nmac" else STATUS_LOWC)
                a.append(index.get(row["ac1"], -1))
                b.append(index.get(row["ac2"], -1))
                start.append(s)
                end.append(e if math.isfinite(e) else math.inf)
                lat.append(la)
                lon.append(lo)
        order = np.argsort(np.asarray(start), kind="stable")
        self._ev_kind = np.asarray(kinds, dtype=np.int8)[order]
        self._ev_a, self._ev_b = np.asarray(a, dtype=np.int64)[order], np.asarray(b, dtype=np.int64)[order]
        self._ev_start, self._ev_end = np.asarray(start)[order], np.asarray(end)[order]
        self._ev_lat, self._ev_lon = np.asarray(lat)[order], np.asarray(lon)[order]
        self._ev_names = [(str(self.callsigns[i]) if i >= 0 else "?", str(self.callsigns[j]) if j >= 0 else "?")
                          for i, j in zip(self._ev_a.tolist(), self._ev_b.tolist())]

    def _read_flights(self, path: Path) -> None:
        self._arrivals = np.zeros(0)
        self.routes_by_id: dict[str, str] = {}
        if not path.is_file():
            return
        import csv

        arrivals = []
        with open(path, newline="", encoding="utf-8", errors="replace") as fh:
            for lineno, row in enumerate(csv.DictReader(fh), start=2):
                try:
                    if row.get("arrived") == "true" and row.get("deleted_s"):
                        arrivals.append(float(row["deleted_s"]))
                except ValueError as exc:
                    raise ReplayError(f"{path}: line {lineno}: {exc}") from None
                if row.get("origin") or row.get("destination"):
                    self.routes_by_id[row.get("id", "")] = f"{row.get('origin', '')}-{row.get('destination', '')}"
        self._arrivals = np.sort(np.asarray(arrivals))

    # ------------------------------------------------------------ queries
    def layout(self) -> MapLayout:
        """The map: the run's scenario network (``scenario.scn``), widened to the flown positions."""
        if self._layout is None:
            scn = self.run_dir / "scenario.scn"
            text = scn.read_text(encoding="utf-8", errors="replace") if scn.is_file() else ""
            self._layout = layout_from_scenario(text, self._lat, self._lon)
        return self._layout

    def _rows_at(self, t: float) -> tuple[int, int, float]:
        k = int(np.searchsorted(self.times, t, side="right")) - 1
        if k < 0:
            return 0, 0, 0.0
        lo, hi = int(self._block[k]), int(self._block[k + 1])
        gap = t - float(self.times[k])
        if k == len(self.times) - 1 and gap > 0:
            return lo, hi, 0.0  # after the last sample: hold the last picture
        return lo, hi, gap

    def frame_at(self, t: float, events_since: float | None = None) -> TrafficFrame:
        """The aircraft of the sample at or before ``t``, moved on to ``t``; events in ``(events_since, t]``."""
        t = float(t)
        lo, hi, gap = self._rows_at(t)
        codes = self._code[lo:hi]
        trk = self._trk[lo:hi]
        lat, lon = self._lat[lo:hi].copy(), self._lon[lo:hi].copy()
        if gap > 0 and hi > lo:
            dist = self._gs[lo:hi] * gap
            rad = np.radians(trk)
            lat += np.degrees(dist * np.cos(rad) / R_EARTH)
            lon += np.degrees(dist * np.sin(rad) / (R_EARTH * np.cos(np.radians(lat))))
        tas = self._tas[lo:hi]
        airborne, status = airborne_status(self._alt[lo:hi], tas, self.hold_speed_mps)
        live = (self._ev_start <= t) & (t <= self._ev_end)
        for code in (STATUS_LOWC, STATUS_NMAC):  # NMAC last: it wins over LoWC
            sel = live & (self._ev_kind == code)
            inside = np.concatenate([self._ev_a[sel], self._ev_b[sel]])
            status[np.isin(codes, inside)] = code
        events: tuple[ConflictEvent, ...] = ()
        if events_since is not None:
            i0 = int(np.searchsorted(self._ev_start, events_since, side="right"))
            i1 = int(np.searchsorted(self._ev_start, t, side="right"))
            events = tuple(
                ConflictEvent("nmac" if self._ev_kind[i] == STATUS_NMAC else "lowc", float(self._ev_start[i]),
                              self._ev_names[i], float(self._ev_lat[i]), float(self._ev_lon[i]))
                for i in range(i0, i1))
        started = int(np.searchsorted(self._ev_start, t, side="right"))
        kinds = self._ev_kind[:started]
        metrics: dict[str, float] = {
            "airborne": int(np.count_nonzero(airborne)),
            "nmac": int(np.count_nonzero(kinds == STATUS_NMAC)),
            "lowc": int(np.count_nonzero(kinds == STATUS_LOWC)),
            "completed": int(np.searchsorted(self._arrivals, t, side="right")),
            "holding": int(np.count_nonzero(status == STATUS_HOLDING)),
        }
        ids = tuple(self.callsigns[codes].tolist())
        return TrafficFrame(t, ids, lat, lon, self._alt[lo:hi].copy(), trk.copy(), tas.copy(), status, events,
                            metrics)

    def airborne_counts(self) -> np.ndarray:
        """Aircraft in each sample (one count per entry of ``times``)."""
        return np.diff(self._block)

    def event_positions(self, kind: str) -> tuple[np.ndarray, np.ndarray]:
        """Mid-point latitudes and longitudes of every ``"lowc"`` or ``"nmac"`` event of the run."""
        sel = self._ev_kind == (STATUS_NMAC if kind == "nmac" else STATUS_LOWC)
        return self._ev_lat[sel], self._ev_lon[sel]

    def trails(self, t: float, seconds: float) -> dict[str, np.ndarray]:
        """Callsign -> (k, 2) lat/lon samples of the last ``seconds`` up to ``t``, oldest first."""
        k1 = int(np.searchsorted(self.times, t, side="right"))
        k0 = int(np.searchsorted(self.times, t - seconds, side="left"))
        lo, hi = int(self._block[k0]), int(self._block[k1]) if k1 > k0 else int(self._block[k0])
        codes = self._code[lo:hi]
        order = np.argsort(codes, kind="stable")  # time order kept within each aircraft
        codes, starts = np.unique(codes[order], return_index=True)
        pts = np.column_stack([self._lat[lo:hi], self._lon[lo:hi]])[order]
        bounds = [*starts.tolist(), len(order)]
        return {str(self.callsigns[c]): pts[bounds[i]:bounds[i + 1]] for i, c in enumerate(codes.tolist())}
