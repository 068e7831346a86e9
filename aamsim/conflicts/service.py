"""Conflict detection and loss-of-separation events, attached to a simulation.

Every ``cd_interval_s`` (1 s, as BlueSky's ASAS timer) the service

* runs state-based conflict detection when ``ASAS``/``CDMETHOD`` is on
  (BlueSky's STATEBASED with ZONER, ZONEDH and DTLOOK): per-aircraft in-conflict
  flags, time to closest approach, and the list of conflict pairs;
* tracks loss-of-separation events for each separation volume (NMAC and LoWC
  by default, the paper's 150 m and 450 m 3-D spheres): an event is one pair
  entering the volume, lasting until it leaves, counted once. Between two
  checks aircraft are assumed to fly straight, and the closest point of
  approach inside the interval is used, so an encounter shorter than the
  interval is not missed;
* keeps each aircraft's distance to its closest intruder and the minimum
  separation seen.

The pair searches use a uniform grid (:mod:`aamsim.conflicts.grid`) instead of
all pairs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aamsim.conflicts.grid import candidate_pairs, local_frame
from aamsim.conflicts.pairs import slant_distances, statebased, volume_encounters
from aamsim.traffic import fields as f
from aamsim.units import R_EARTH

if TYPE_CHECKING:
    from aamsim.simulation import Simulation

EXTENSION_KEY = "conflicts"


@dataclass(frozen=True)
class SeparationVolume:
    """A sphere (3-D slant distance < radius) or a cylinder (|dh| < radius and |dz| < half_height)."""

    name: str
    radius_m: float
    half_height_m: float | None = None

    @property
    def cylinder(self) -> bool:
        return self.half_height_m is not None

    def describe(self) -> str:
        if self.cylinder:
            return f"{self.name}: cylinder r={self.radius_m:g} m, h=+-{self.half_height_m:g} m"
        return f"{self.name}: sphere r={self.radius_m:g} m (3-D slant)"


PAPER_VOLUMES = (SeparationVolume("nmac", 150.0), SeparationVolume("lowc", 450.0))


@dataclass
class SeparationEvent:
    """One pair inside one volume, from entry to exit; positions at the closest point."""

    volume: str
    ac1: str
    ac2: str
    start_s: float
    end_s: float = math.nan
    min_dist_m: float = math.inf
    t_min_s: float = math.nan
    pos1: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    pos2: tuple[float, float, float] = (math.nan, math.nan, math.nan)

    @property
    def active(self) -> bool:
        return math.isnan(self.end_s)

    def duration_s(self, now_s: float) -> float:
        return (now_s if self.active else self.end_s) - self.start_s


@dataclass(frozen=True)
class ConflictState:
    """Result of one state-based detection (pairs i < j as callsigns)."""

    pairs: tuple[tuple[str, str], ...]
    tcpa_s: np.ndarray
    dcpa_m: np.ndarray
    tinconf_s: np.ndarray
    los_pairs: tuple[tuple[str, str], ...]
    inconf: np.ndarray  # per traffic slot at the time of detection
    tcpamax_s: np.ndarray


@dataclass
class _Snapshot:
    ids: list[str]
    lat: np.ndarray
    lon: np.ndarray
    alt: np.ndarray
    u: np.ndarray
    v: np.ndarray
    w: np.ndarray
    x: np.ndarray
    y: np.ndarray
    frame_err: float


def _snapshot(sim: Simulation) -> _Snapshot:
    t = sim.traffic
    n = t.n
    F = t.F
    trk = np.radians(F[f.TRK, :n])
    gs = F[f.GS, :n]
    lat = F[f.LAT, :n].copy()
    lon = F[f.LON, :n].copy()
    x, y, err = local_frame(lat, lon)
    return _Snapshot(list(t.ids), lat, lon, F[f.ALT, :n].copy(), gs * np.sin(trk), gs * np.cos(trk),
                     F[f.VS, :n].copy(), x, y, err)


def _boxes(s: _Snapshot, t0: np.ndarray, t1: np.ndarray, grow: float) -> tuple[np.ndarray, ...]:
    """Boxes around each aircraft's straight path between times t0 and t1 (relative to now)."""
    xa = s.x + s.u * t0
    xb = s.x + s.u * t1
    ya = s.y + s.v * t0
    yb = s.y + s.v * t1
    return (np.minimum(xa, xb) - grow, np.maximum(xa, xb) + grow, np.minimum(ya, yb) - grow,
            np.maximum(ya, yb) + grow)


def search_pairs(s: _Snapshot, t0: np.ndarray, t1: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Candidate pairs whose straight paths over [t0, t1] come within ``radius`` (superset)."""
    n = len(s.ids)
    if n < 2:
        empty = np.empty(0, dtype=np.int64)
        return empty, empty
    reach = float(np.max(np.abs(t0) + np.abs(t1)) * 2.0 * np.max(np.hypot(s.u, s.v))) + radius
    grow = 0.5 * radius * (1.0 + s.frame_err) + s.frame_err * reach + 1.0
    xmin, xmax, ymin, ymax = _boxes(s, t0, t1, grow)
    extent = float(np.median(np.maximum(xmax - xmin, ymax - ymin)))
    return candidate_pairs(xmin, xmax, ymin, ymax, max(extent, 2.0 * grow, 1.0))


@dataclass
class ConflictService:
    """Per-simulation conflict detection, events and closest-intruder distances."""

    volumes: tuple[SeparationVolume, ...] = PAPER_VOLUMES
    closest_range_m: float = 3000.0
    events: list[SeparationEvent] = field(default_factory=list)
    state: ConflictState | None = None
    conflict_pairs_total: int = 0  # new conflict pairs (i<j) over the run
    min_separation_m: float = math.inf
    closest_dist_m: dict[str, float] = field(default_factory=dict)
    _active: dict[tuple[str, str, str], SeparationEvent] = field(default_factory=dict)
    _conflicts_now: set[tuple[str, str]] = field(default_factory=set)
    _last_check_s: dict[str, float] = field(default_factory=dict)

    # ------------------------------------------------------------- lifecycle
    def attach(self, sim: Simulation) -> None:
        sim.extensions[EXTENSION_KEY] = self
        sim.hooks.post_step.add(self.check, interval_s=sim.settings.cd_interval_s, name="conflicts", priority=10)
        sim.hooks.deleted.add(self.on_deleted, name="conflicts.deleted")
        sim.hooks.reset.add(self.on_reset, name="conflicts.reset")

    def on_reset(self, sim: Simulation) -> None:
        self.finish(sim)
        self._active.clear()
        self._conflicts_now.clear()
        self._last_check_s.clear()
        self.state = None
        self.closest_dist_m.clear()

    def set_volume(self, volume: SeparationVolume) -> None:
        self.volumes = tuple(v for v in self.volumes if v.name != volume.name) + (volume,)

    def volume(self, name: str) -> SeparationVolume:
        for vol in self.volumes:
            if vol.name == name:
                return vol
        raise KeyError(name)

    # ---------------------------------------------------------------- checks
    def _lookback(self, sim: Simulation, s: _Snapshot) -> np.ndarray:
        now = sim.simt
        created = sim.traffic.F[f.CREATED_S, : len(s.ids)]
        last = np.array([self._last_check_s.get(a, -math.inf) for a in s.ids])
        since = np.minimum(now - last, now - created)
        return np.maximum(since, 0.0)

    def check(self, sim: Simulation) -> None:
        """Run all detections on the current state (the post-step hook)."""
        now = sim.simt
        s = _snapshot(sim)
        n = len(s.ids)
        if sim.settings.cd_method != "OFF":
            self._detect_conflicts(sim, s)
        elif self.state is not None:
            self.state = None
            self._conflicts_now.clear()
        lookback = self._lookback(sim, s)
        self._track_events(now, s, lookback, np.arange(n))
        self._closest(s)
        for acid in s.ids:
            self._last_check_s[acid] = now

    def _detect_conflicts(self, sim: Simulation, s: _Snapshot) -> None:
        st = sim.settings
        n = len(s.ids)
        zeros = np.zeros(n)
        horizon = np.full(n, st.dtlook_s)
        pi, pj = search_pairs(s, zeros, horizon, st.zoner_m)
        conf, tcpa, dcpa, tin, _tout, los = statebased(s.lat, s.lon, s.alt, s.u, s.v, s.w, pi, pj,
                                                       st.zoner_m, st.zonedh_m, st.dtlook_s)
        ci, cj = pi[conf], pj[conf]
        pairs = tuple((s.ids[a], s.ids[b]) for a, b in zip(ci, cj))
        inconf = np.zeros(n, dtype=bool)
        inconf[ci] = True
        inconf[cj] = True
        tcpamax = np.zeros(n)
        np.maximum.at(tcpamax, ci, tcpa[conf])
        np.maximum.at(tcpamax, cj, tcpa[conf])
        los_pairs = tuple((s.ids[a], s.ids[b]) for a, b in zip(pi[los], pj[los]))
        self.state = ConflictState(pairs, tcpa[conf], dcpa[conf], tin[conf], los_pairs, inconf, tcpamax)
        now_set = set(pairs)
        self.conflict_pairs_total += len(now_set - self._conflicts_now)
        self._conflicts_now = now_set

    def _track_events(self, now: float, s: _Snapshot, lookback: np.ndarray, subset: np.ndarray) -> None:
        if not self.volumes:
            return
        n = len(s.ids)
        radius = max(v.radius_m for v in self.volumes)
        pi, pj = search_pairs(s, -lookback, np.zeros(n), radius)
        if len(subset) < n:
            keep = np.isin(pi, subset) | np.isin(pj, subset)
            pi, pj = pi[keep], pj[keep]
        for vol in self.volumes:
            inside, t_in, t_out, dmin, t_min = volume_encounters(
                s.lat, s.lon, s.alt, s.u, s.v, s.w, lookback, pi, pj, vol.cylinder, vol.radius_m,
                vol.half_height_m if vol.cylinder else 0.0,
            )
            seen: set[tuple[str, str, str]] = set()
            for k in np.flatnonzero(inside):
                i, j = int(pi[k]), int(pj[k])
                a, b = s.ids[i], s.ids[j]
                key = (vol.name, a, b) if a < b else (vol.name, b, a)
                seen.add(key)
                event = self._active.get(key)
                if event is None:
                    event = SeparationEvent(vol.name, key[1], key[2], now + float(t_in[k]))
                    self._active[key] = event
                    self.events.append(event)
                if dmin[k] < event.min_dist_m:
                    event.min_dist_m = float(dmin[k])
                    tau = float(t_min[k])
                    event.t_min_s = now + tau
                    event.pos1 = _extrapolate(s, i, tau)
                    event.pos2 = _extrapolate(s, j, tau)
                if t_out[k] < -1e-9:  # left the volume before now
                    event.end_s = now + float(t_out[k])
                    del self._active[key]
            # Active events of this volume not seen this interval have ended.
            checked = set(s.ids[int(x)] for x in subset)
            for key in [k for k in self._active if k[0] == vol.name and k not in seen]:
                if key[1] in checked or key[2] in checked:
                    event = self._active.pop(key)
                    event.end_s = now - float(np.min(lookback)) if len(lookback) else now

    def _closest(self, s: _Snapshot) -> None:
        n = len(s.ids)
        dist = np.full(n, math.inf)
        if n >= 2:
            zeros = np.zeros(n)
            pi, pj = search_pairs(s, zeros, zeros, self.closest_range_m)
            d = slant_distances(s.lat, s.lon, s.alt, pi, pj)
            np.minimum.at(dist, pi, d)
            np.minimum.at(dist, pj, d)
        self.closest_dist_m = dict(zip(s.ids, dist.tolist()))
        finite = dist[np.isfinite(dist)]
        if len(finite):
            self.min_separation_m = min(self.min_separation_m, float(finite.min()))
        for ev in self._active.values():
            self.min_separation_m = min(self.min_separation_m, ev.min_dist_m)

    def on_deleted(self, sim: Simulation, slot: int, record: object) -> None:
        """Check the deleted aircraft's last interval before it disappears."""
        s = _snapshot(sim)
        lookback = self._lookback(sim, s)
        self._track_events(sim.simt, s, lookback, np.array([slot]))
        acid = s.ids[slot]
        for key in [k for k in self._active if acid in k[1:]]:
            self._active.pop(key).end_s = sim.simt
        self._last_check_s.pop(acid, None)
        self.closest_dist_m.pop(acid, None)

    def finish(self, sim: Simulation) -> None:
        """Close events still open at the end of the run (end time = now)."""
        for event in self._active.values():
            event.end_s = sim.simt
        self._active.clear()

    # -------------------------------------------------------------- queries
    def count(self, volume: str) -> int:
        return sum(1 for e in self.events if e.volume == volume)

    def in_volume_now(self, volume: str) -> set[str]:
        """Callsigns currently inside an open event of ``volume``."""
        out: set[str] = set()
        for key in self._active:
            if key[0] == volume:
                out.update(key[1:])
        return out


def _extrapolate(s: _Snapshot, i: int, tau: float) -> tuple[float, float, float]:
    lat = s.lat[i] + math.degrees(s.v[i] * tau / R_EARTH)
    lon = s.lon[i] + math.degrees(s.u[i] * tau / (R_EARTH * max(1e-6, math.cos(math.radians(s.lat[i])))))
    return float(lat), float(lon), float(s.alt[i] + s.w[i] * tau)


def closest_intruders(sim: Simulation, max_range_m: float = 3000.0) -> tuple[np.ndarray, np.ndarray]:
    """Distance [m] (3-D) from each aircraft to its closest intruder now, and that intruder's slot.

    Beyond ``max_range_m`` the distance is ``inf`` and the slot -1.
    """
    s = _snapshot(sim)
    n = len(s.ids)
    dist = np.full(n, math.inf)
    idx = np.full(n, -1, dtype=np.int64)
    if n < 2:
        return dist, idx
    zeros = np.zeros(n)
    pi, pj = search_pairs(s, zeros, zeros, max_range_m)
    d = slant_distances(s.lat, s.lon, s.alt, pi, pj)
    ok = d <= max_range_m
    for a, b, dd in zip(pi[ok], pj[ok], d[ok]):
        if dd < dist[a]:
            dist[a], idx[a] = dd, b
        if dd < dist[b]:
            dist[b], idx[b] = dd, a
    return dist, idx


def conflicts_of(sim: Simulation) -> ConflictService:
    """The conflict service of a simulation (attached on first use)."""
    service = sim.extensions.get(EXTENSION_KEY)
    if service is None:
        service = ConflictService()
        service.attach(sim)
    return service
