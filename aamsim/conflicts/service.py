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
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.compiled_errors import raise_original
from aamsim.conflicts.events import EventLog, SeparationEvent
from aamsim.conflicts.fused import detect_all, new_pair_count, pairs_now, volume_pass
from aamsim.conflicts.grid import NO_PAIR_LIMIT, candidate_pairs, snapshot_arrays, swept_boxes
from aamsim.conflicts.pairs import nearest_per_aircraft, slant_distances
from aamsim.conflicts.separation import LOWC, NMAC, PAPER_STANDARD, SeparationStandard, SeparationVolume
from aamsim.conflicts.zone_advice import zone_advice
from aamsim.hooks import sleep_while_unchanged
from aamsim.traffic.view import field_rows, kinematic_matrix
from aamsim.units import R_EARTH

if TYPE_CHECKING:
    from aamsim.simapi import SimulationCore
    from aamsim.traffic.traffic import Traffic

# Pairs one check handles, per search (conflicts, losses of separation, pairs near enough for a volume):
# MAX_PAIRS_PER_CHECK, or PAIRS_PER_AIRCRAFT per aircraft when that is more. Aircraft created on one spot
# put every pair in conflict: 3,000 of them (4.5 million pairs) made one step take 53 s and 4.5 GB; past the
# bound a check stops, with an error, and the step's work stays bounded (linear in the aircraft). Dense but
# spread traffic stays below it: a flat 100,000 cut the checks of 10,000 aircraft in a 60 km box
# (bench/bench_conflicts.py: 125,768 NMACs counted instead of 127,500).
MAX_PAIRS_PER_CHECK = 100_000
PAIRS_PER_AIRCRAFT = 100


def pair_bound(n: int) -> int:
    """The pairs one search of a check among ``n`` aircraft handles before it stops."""
    return max(MAX_PAIRS_PER_CHECK, PAIRS_PER_AIRCRAFT * n)

# The state the compiled passes read, in the order they expect it.
_KINEMATIC_FIELDS = ("lat", "lon", "alt", "gseast", "gsnorth", "vs")
_SNAPSHOT_ROWS = field_rows(_KINEMATIC_FIELDS)


PAPER_VOLUMES = PAPER_STANDARD.volumes()


@dataclass(frozen=True)
class ConflictState:
    """Result of one state-based detection: conflict pairs (slots i < j at detection time)."""

    ids: tuple[str, ...]  # callsign per slot at detection time
    pi: np.ndarray
    pj: np.ndarray
    tcpa_s: np.ndarray
    dcpa_m: np.ndarray
    tinconf_s: np.ndarray
    los_pi: np.ndarray
    los_pj: np.ndarray
    inconf: np.ndarray  # per slot
    tcpamax_s: np.ndarray

    @property
    def pairs(self) -> tuple[tuple[str, str], ...]:
        """Conflict pairs as callsigns (each unordered pair once; BlueSky lists both orders)."""
        return tuple((self.ids[a], self.ids[b]) for a, b in zip(self.pi.tolist(), self.pj.tolist()))

    @property
    def los_pairs(self) -> tuple[tuple[str, str], ...]:
        return tuple((self.ids[a], self.ids[b]) for a, b in zip(self.los_pi.tolist(), self.los_pj.tolist()))


@dataclass
class TrafficSnapshot:
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
    frame: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # pair-formula terms (pairs.pair_frame)


def traffic_snapshot(sim: SimulationCore) -> TrafficSnapshot:
    """Positions, velocities (east, north, up) and the local frame of all aircraft now."""
    t = sim._traffic
    matrix, rows = kinematic_matrix(t, _KINEMATIC_FIELDS)
    lat, lon, alt, u, v, w, x, y, err, *frame = snapshot_arrays(matrix, t.n, rows, R_EARTH)
    return TrafficSnapshot(list(t.ids), lat, lon, alt, u, v, w, x, y, err, tuple(frame))  # type: ignore[arg-type]


def search_pairs(s: TrafficSnapshot, t0: np.ndarray, t1: np.ndarray, radius: float,
                 limit: int = NO_PAIR_LIMIT) -> tuple[np.ndarray, np.ndarray]:
    """Candidate pairs whose straight paths over [t0, t1] come within ``radius`` (superset).

    ``limit``: stop once this many are found (see :func:`aamsim.conflicts.grid.candidate_pairs`).
    """
    if len(s.ids) < 2:
        empty = np.empty(0, dtype=np.int64)
        return empty, empty
    xmin, xmax, ymin, ymax, cell = swept_boxes(s.x, s.y, s.u, s.v, t0, t1, radius, s.frame_err)
    return candidate_pairs(xmin, xmax, ymin, ymax, cell, limit)


@dataclass
class ConflictService:
    """Per-simulation conflict detection, events and closest-intruder distances."""

    volumes: tuple[SeparationVolume, ...] = PAPER_VOLUMES
    closest_range_m: float = 1000.0  # closest-intruder distances and minimum separation below this range
    logs: dict[str, EventLog] = field(default_factory=dict)
    state: ConflictState | None = None
    conflict_pairs_total: int = 0  # new conflict pairs (i<j) over the run
    checks_cut: int = 0  # checks whose pair search stopped at pair_bound(n)
    checks_skipped: int = 0  # checks that ran out of memory (reported once)
    min_separation_m: float = math.inf
    _closest_ids: tuple[str, ...] = ()
    _closest_arr: np.ndarray = field(default_factory=lambda: np.empty(0))
    _conflict_keys: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    _serials: dict[str, int] = field(default_factory=dict)
    _serial_array: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    _rank_array: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))  # callsign order per slot
    _volume_cache: tuple | None = None
    _standard_cache: tuple | None = None  # (volumes, their SeparationStandard): rewards read it every step
    _serial_version: tuple | None = None  # (traffic, layout version) the serial cache was built for
    _conflicts_hint: int = 0  # conflicts at the last check: sizes the next check's output
    _hook: Any = None  # the check's post-step hook (it sleeps while paused)
    _last_check_s: float = -math.inf
    _zone_advised: bool = False  # the airliner-zone warning (zone_advice) was given
    # While True, a check only moves the time its successor looks back to, and a deletion is not
    # checked: nothing is detected or recorded (no events, conflicts, closest distances). For a
    # view that reads nobody's separation for a while: a single-agent episode before its ego exists
    # (rlbridge.core.EpisodeCore.until_alive_steps). The first check after it looks back one
    # interval, as it would have; an event open when the pause began is closed by that check.
    paused: bool = False

    # ------------------------------------------------------------- lifecycle
    def attach(self, sim: SimulationCore) -> None:
        # The interval is read from the settings each time the check runs, so DT ASAS takes effect.
        self._hook = sim.hooks.post_step.add(self.check, interval_s=lambda: sim.settings.cd_interval_s,
                                             name="conflicts", priority=10)
        sim.hooks.deleted.add(self.on_deleted, name="conflicts.deleted")
        sim.hooks.reset.add(self.on_reset, name="conflicts.reset")

    def on_reset(self, sim: SimulationCore) -> None:
        self.finish(sim)
        self.paused = False
        self._conflict_keys = np.empty(0, dtype=np.int64)
        self._serials.clear()
        self._serial_version = None
        self._last_check_s = -math.inf
        self._zone_advised = False
        self.state = None
        self._closest_ids, self._closest_arr = (), np.empty(0)

    def set_volume(self, volume: SeparationVolume) -> None:
        self.volumes = tuple(v for v in self.volumes if v.name != volume.name) + (volume,)

    @property
    def standard(self) -> SeparationStandard:
        """The separation standard: this service's ``nmac`` and ``lowc`` volumes (``SEPVOLUME`` changes them)."""
        vols = self.volumes
        cache = self._standard_cache
        if cache is not None and cache[0] is vols:  # volumes change by replacing the tuple (set_volume)
            return cache[1]
        try:
            standard = SeparationStandard.from_volumes(self.volume(NMAC), self.volume(LOWC))
        except KeyError as exc:
            raise LookupError(f"the conflict service has no {exc.args[0]!r} volume, so no separation standard "
                              f"(its volumes: {', '.join(v.name for v in vols)})") from None
        self._standard_cache = (vols, standard)
        return standard

    def set_standard(self, standard: SeparationStandard) -> None:
        """Use ``standard``'s NMAC and LoWC volumes from now on (other volumes stay)."""
        for volume in standard.volumes():
            self.set_volume(volume)

    def volume(self, name: str) -> SeparationVolume:
        for vol in self.volumes:
            if vol.name == name:
                return vol
        raise KeyError(name)

    # ---------------------------------------------------------------- checks
    def _lookback(self, sim: SimulationCore, n: int) -> np.ndarray:
        """Per aircraft, how far back the last interval reaches: to the last check or its creation."""
        now = sim.simt
        created = sim.view.created_s[:n]
        return np.maximum(np.minimum(now - self._last_check_s, now - created), 0.0)

    def check(self, sim: SimulationCore) -> None:
        """Run all detections on the current state (the post-step hook).

        An exception that interrupts one of its compiled passes (Ctrl-C, an alarm, a MemoryError) is raised as
        itself, not as Numba's opaque ``SystemError`` (:mod:`aamsim.compiled_errors`); a MemoryError in the
        detection pass, whose memory grows with the pairs it finds, skips the check with an error instead.
        """
        if self.paused:
            self._last_check_s = sim.simt
            self._sleep(sim)
            return
        try:
            self._check(sim)
        except SystemError as exc:  # a try costs nothing when nothing is raised; a `with` did, per check
            raise_original(exc)

    def _sleep(self, sim: SimulationCore) -> None:
        """Paused: sleep until the pause ends or DT ASAS or DT changes (a check ended a batch every second).

        Each check slept through would only have moved the look-back origin to its time.
        """
        def woken(slept_through_us: int | None) -> None:
            if slept_through_us is not None:
                self._last_check_s = slept_through_us / 1_000_000  # as sim.simt then

        sleep_while_unchanged(sim.hooks.post_step, self._hook, sim._clock, lambda: self.paused, woken)

    def _check(self, sim: SimulationCore) -> None:
        t = sim._traffic
        st = sim.settings
        n = t.n
        cd_on = st.cd_method != "OFF"
        radii, cylinder, half_heights = self._volume_arrays()
        matrix, rows = kinematic_matrix(t, _KINEMATIC_FIELDS)
        max_pairs = pair_bound(n)
        try:
            # An interruption (Ctrl-C, an alarm) or a MemoryError while the compiled pass hands its arrays
            # back arrives as its own exception, not as Numba's opaque SystemError (aamsim.compiled_errors).
            try:
                found = detect_all(
                    matrix, n, rows, R_EARTH, self._lookback(sim, n), cd_on, st.zoner_m, st.zonedh_m, st.dtlook_s,
                    radii, cylinder, half_heights, self.closest_range_m, self._conflicts_hint, max_pairs)
            except SystemError as exc:
                raise_original(exc)
        except MemoryError:
            # The next check that fits looks back to the last one that ran (_lookback), so the events of
            # the skipped interval are still found then.
            self.checks_skipped += 1
            if self.checks_skipped == 1:
                sim.report("error", f"conflict detection: out of memory at t = {sim.simt:.2f} s ({n:,} aircraft); "
                                    "this check was skipped, as is each later one that runs out of memory (the "
                                    "next check that runs covers the time since the last one)")
            return
        self._conflicts_hint = len(found.conflict_i) + len(found.conflict_i) // 4
        if found.cut:
            self.checks_cut += 1
            if self.checks_cut == 1:
                sim.report("error", f"conflict detection: over {max_pairs:,} aircraft pairs close together "
                                    f"at t = {sim.simt:.2f} s ({n:,} aircraft); each check stops at "
                                    f"{max_pairs:,} pairs, so conflicts and separation events past them "
                                    "are missing (traffic created on one spot?)")
        ids_now = tuple(t.ids)
        if cd_on and not self._zone_advised and n:
            advice = zone_advice(sim)
            if advice is not None:
                self._zone_advised = True
                sim.report("warning", advice)
        if cd_on:
            self.state = ConflictState(ids_now, found.conflict_i, found.conflict_j, found.tcpa, found.dcpa,
                                       found.tinconf, found.los_i, found.los_j, found.inconf, found.tcpamax)
            self._count_new_conflicts(self._serials_of(t)[0], found.conflict_i, found.conflict_j)
        elif self.state is not None:
            self.state = None
            self._conflict_keys = np.empty(0, dtype=np.int64)
        lo = 0
        for q, vol in enumerate(self.volumes):
            hi = lo + int(found.inside_count[q])  # inside pairs come grouped by volume
            log = self._log(vol.name)
            if hi > lo or len(log.open_keys):
                self._merge_events(log, sim.simt, t, found.event_i[lo:hi], found.event_j[lo:hi],
                                   found.event_t_in[lo:hi], found.event_t_out[lo:hi], found.event_dmin[lo:hi],
                                   found.event_t_min[lo:hi], found.event_state[lo:hi], None)
            lo = hi
        self._closest_ids, self._closest_arr = ids_now, found.closest
        self.min_separation_m = min(self.min_separation_m, found.min_distance)
        self._last_check_s = sim.simt

    def _volume_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        vols = self.volumes
        if self._volume_cache is None or self._volume_cache[0] is not vols:
            self._volume_cache = (vols, np.array([v.radius_m for v in vols], dtype=np.float64),
                                  np.array([v.cylinder for v in vols], dtype=np.bool_),
                                  np.array([v.half_height_m or 0.0 for v in vols], dtype=np.float64))
        return self._volume_cache[1], self._volume_cache[2], self._volume_cache[3]

    def _count_new_conflicts(self, serial: np.ndarray, ci: np.ndarray, cj: np.ndarray) -> None:
        """Count conflict pairs that were not in conflict at the previous detection."""
        new, self._conflict_keys = new_pair_count(serial, ci, cj, self._conflict_keys)
        self.conflict_pairs_total += new

    def _serial(self, acid: str) -> int:
        serial = self._serials.get(acid)
        if serial is None:
            serial = self._serials[acid] = len(self._serials)
        return serial

    def _log(self, volume: str) -> EventLog:
        log = self.logs.get(volume)
        if log is None:
            log = self.logs[volume] = EventLog(volume)
        return log

    def _serials_of(self, traffic: Traffic) -> tuple[np.ndarray, np.ndarray]:
        """Per slot, the aircraft's serial number (stable over the run, unlike slots) and its callsign's rank
        in sorting order (events name a pair in that order); rebuilt when aircraft are created or deleted."""
        version = (traffic, traffic.layout_version)
        if self._serial_version is None or self._serial_version[0] is not traffic \
                or self._serial_version[1] != version[1]:
            ids = traffic.ids
            self._serial_array = np.fromiter((self._serial(a) for a in ids), dtype=np.int64, count=len(ids))
            self._rank_array = np.empty(len(ids), dtype=np.int64)
            self._rank_array[np.argsort(np.array(ids, dtype=object), kind="stable")] = np.arange(len(ids))
            self._serial_version = version
        return self._serial_array, self._rank_array

    def _merge_events(self, log: EventLog, now: float, traffic: Traffic, ii: np.ndarray, jj: np.ndarray,
                      t_in: np.ndarray, t_out: np.ndarray, dmin: np.ndarray, t_min: np.ndarray, cpa: np.ndarray,
                      only: str | None) -> None:
        """Merge one check's inside pairs (slots ii, jj; ``cpa``: their state at t_min) into a volume's log.

        ``only``: restrict closing unseen open events to those of this callsign
        (the last check of a deleted aircraft).
        """
        serial, rank = self._serials_of(traffic)
        unseen_filter = None if only is None else _open_keys_of(log, self._serial(only))
        log.update(now, self._last_check_s, traffic.ids, ii, jj, serial, rank, t_in, t_out, dmin, t_min, cpa,
                   unseen_filter)

    def on_deleted(self, sim: SimulationCore, slot: int, record: object) -> None:
        """Check the deleted aircraft's last interval before it disappears."""
        if self.paused:
            return
        if self._hook is not None and self._hook.wake is not None:
            # The pause ended since the last boundary (a deletion in the same commands, or through the
            # API): the check wakes now, so that the look-back starts at the last check it slept through.
            sim.hooks.post_step.wake_sleepers(sim._clock.simt_us, sim)
        s = traffic_snapshot(sim)
        n = len(s.ids)
        lookback = self._lookback(sim, n)
        radius = max(v.radius_m for v in self.volumes) if self.volumes else 0.0
        others = np.delete(np.arange(n, dtype=np.int64), slot)
        pi = np.minimum(others, slot)
        pj = np.maximum(others, slot)
        acid = s.ids[slot]
        if radius > 0 and n > 1:
            d = slant_distances(s.lat, s.lon, s.alt, pi, pj)
            reach = radius + 2.0 * float(np.max(np.hypot(s.u, s.v))) * float(np.max(lookback, initial=0.0)) + 1.0
            near = d <= reach
            radii, cylinder, half_heights = self._volume_arrays()
            _q, ei, ej, e_in, e_out, e_dmin, e_tmin, e_pos, count, _closest, dnow = volume_pass(
                s.lat, s.lon, *s.frame, s.alt, s.u, s.v, s.w, lookback, pi[near], pj[near], radii, cylinder,
                half_heights, 0.0, R_EARTH)
            lo = 0
            for q, vol in enumerate(self.volumes):
                hi = lo + int(count[q])
                log = self._log(vol.name)
                if hi > lo or len(log.open_keys):
                    self._merge_events(log, sim.simt, sim._traffic, ei[lo:hi], ej[lo:hi], e_in[lo:hi],
                                       e_out[lo:hi], e_dmin[lo:hi], e_tmin[lo:hi], e_pos[lo:hi], acid)
                lo = hi
            self.min_separation_m = min(self.min_separation_m, dnow)
        for log in self.logs.values():
            log.close_all(sim.simt, _open_keys_of(log, self._serial(acid)))

    def finish(self, sim: SimulationCore) -> None:
        """Close events still open at the end of the run (end time = now)."""
        for log in self.logs.values():
            log.close_all(sim.simt)

    # -------------------------------------------------------------- queries
    @property
    def closest_dist_m(self) -> dict[str, float]:
        """Distance [m] to the closest intruder at the last check (inf beyond ``closest_range_m``)."""
        return dict(zip(self._closest_ids, self._closest_arr.tolist()))

    @property
    def events(self) -> list[SeparationEvent]:
        """Every event of every volume, by start time (built on demand from the logs)."""
        out = [e for log in self.logs.values() for e in log.events()]
        out.sort(key=lambda e: (e.start_s, e.volume, e.ac1, e.ac2))
        return out

    def count(self, volume: str) -> int:
        log = self.logs.get(volume)
        return log.n if log is not None else 0

    def in_volume_now(self, volume: str) -> set[str]:
        """Callsigns currently inside an open event of ``volume``."""
        log = self.logs.get(volume)
        return log.open_callsigns() if log is not None else set()

    def started_since(self, volume: str, t0: float) -> list[SeparationEvent]:
        """Events of ``volume`` that began after ``t0`` (a viewer flashes them), by start time."""
        log = self.logs.get(volume)
        if log is None or log.n == 0:
            return []
        rows = np.flatnonzero(log.start[:log.n] > t0)  # rows of one check are not in start order
        return sorted((log.event(r) for r in rows.tolist()), key=lambda e: (e.start_s, e.ac1, e.ac2))

    def involved_since(self, volume: str, t0: float) -> dict[str, float]:
        """Callsign -> smallest distance in ``volume`` events open at some time since ``t0``."""
        log = self.logs.get(volume)
        return log.involved_since(t0) if log is not None else {}


def _open_keys_of(log: EventLog, serial: int) -> np.ndarray:
    """The open events' keys of one aircraft (a key packs the pair's two serials)."""
    keys = log.open_keys
    return keys[((keys >> 32) == serial) | ((keys & 0xFFFFFFFF) == serial)]


def closest_intruders(sim: SimulationCore, max_range_m: float = 3000.0) -> tuple[np.ndarray, np.ndarray]:
    """Distance [m] (3-D) from each aircraft to its closest intruder now, and that intruder's slot.

    Beyond ``max_range_m`` the distance is ``inf`` and the slot -1.
    """
    pi, pj, d = pairs_within(sim, max_range_m)
    return nearest_per_aircraft(sim._traffic.n, pi, pj, d, max_range_m)


def pairs_within(sim: SimulationCore, radius_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Aircraft pairs (slots ``pi < pj``) now within ``radius_m`` horizontally or closer, and their 3-D distances.

    The pair search is a superset: filter on the distances for an exact radius. It stops at
    :func:`pair_bound` pairs, with an error the first time (aircraft piled on one spot).
    """
    t = sim._traffic
    matrix, rows = kinematic_matrix(t, _KINEMATIC_FIELDS)
    bound = pair_bound(t.n)
    pi, pj, d = pairs_now(matrix, t.n, rows, R_EARTH, radius_m, bound)
    if len(pi) >= bound:
        sim.note_once("pairs_within:cut", f"over {bound:,} aircraft pairs within {radius_m:g} m at "
                                          f"t = {sim.simt:.2f} s; searches for near aircraft stop there, so some "
                                          "near aircraft are left out (traffic created on one spot?)")
    return pi, pj, d
