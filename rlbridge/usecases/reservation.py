"""4-D operational intents and their reservation in space-time (UTM-style strategic deconfliction).

A flight's **intent** is the trajectory it flies as filed, unequipped: sampled
from a probe simulation of the scenario (every request's block at its filed
time, nothing else acting), as positions relative to its departure. Without a
tactical layer flights do not interact, so one probe run gives every flight's
intent; delaying a flight shifts it in time and changing its layer shifts it
vertically.

The :class:`IntentTable` holds the intents of the flights planned so far on an
absolute time grid (``grid_s``) in a local east/north frame [m]. A candidate
(departure time, altitude) **conflicts** with a reserved flight when, on some
grid interval, the 3-D distance between the two — both moving in straight
lines between grid points — falls below ``separation_m`` (a sphere, as the
simulation's LoWC volume). This is the check UTM's operational-intent
negotiation makes before it accepts a flight.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aamsim.conflicts.separation import PAPER_STANDARD
from aamsim.units import R_EARTH as R_EARTH_M
from rlbridge.usecases.schedule import DepartureRequest, Schedule

if TYPE_CHECKING:
    from aamsim import Simulation


@dataclass(frozen=True)
class Intent:
    """A flight's filed trajectory relative to its departure (SI; positions in degrees)."""

    t_rel: np.ndarray  # [s] from departure, increasing, t_rel[0] = 0
    lat: np.ndarray
    lon: np.ndarray
    alt_m: float  # altitude flown from creation [m] (its layer, with the scenario's noise)
    origin: str
    destination: str
    filed_alt_m: float = math.nan  # altitude the scenario creates it at [m]
    scheduled_arrival_s: float = math.nan  # its filed arrival (the RTA at its destination) [s of sim time]

    @property
    def duration_s(self) -> float:
        return float(self.t_rel[-1])


def probe_intents(sim: Simulation, schedule: Schedule, sample_s: float, limit_s: float,
                  layers_m: np.ndarray | None = None, layer: int | None = None) -> dict[str, Intent]:
    """Fly the scenario as filed in a fresh simulation and sample each request's flight.

    ``sim`` lends its time step and scenario files (PCALL search path); the
    probe has no services and nothing acting on the traffic. With ``layer``,
    every request's aircraft moves at creation from its nearest layer of
    ``layers_m`` to that one (its noise kept): a layer changes the true
    airspeed a selected CAS gives, hence the timing along the route. A request
    whose aircraft is never created (a bad CRE line) has no intent.
    """
    from aamsim import Simulation  # the probe is a simulation of its own

    probe = Simulation(seed=0, dt=sim.dt)
    probe.files.search_path[:0] = sim.files.search_path
    probe.files.guard = sim.files.guard  # a server's scenario roots bind the probe's PCALLs too
    probe.limits = sim.limits
    probe.queue.extend(list(schedule.other))  # waypoints, wind, settings, background traffic
    by_acid: dict[str, list[DepartureRequest]] = {}
    for r in schedule.requests:
        by_acid.setdefault(r.acid, []).append(r)
        probe.queue.extend(list(r.commands))
    live: dict[str, tuple[str, list[tuple[float, float, float, float]]]] = {}  # acid -> (key, samples)
    done: dict[str, tuple[list[tuple[float, float, float, float]], str, str, float]] = {}
    filed: dict[str, float] = {}

    def sample(s: Simulation, acid: str, samples: list[tuple[float, float, float, float]]) -> None:
        i = s.view.slot(acid)
        samples.append((s.simt, float(s.view.lat[i]), float(s.view.lon[i]), float(s.view.alt[i])))

    def created(s: Simulation, slot: int) -> None:
        acid = s.view.ids[slot]
        mine = [r for r in by_acid.get(acid, ()) if r.request_s <= s.simt + 1e-6 and r.key not in done]
        if mine:
            filed[mine[-1].key] = float(s.view.alt[slot])
            if layers_m is not None and layer is not None and len(layers_m):
                near = int(np.argmin(np.abs(layers_m - s.view.alt[slot])))
                if near != layer:
                    s.offset_altitude(slot, float(layers_m[layer] - layers_m[near]))
            live[acid] = (mine[-1].key, [])
            sample(s, acid, live[acid][1])

    def deleted(s: Simulation, slot: int, record: object) -> None:
        acid = s.view.ids[slot]
        if acid in live:
            key, samples = live.pop(acid)
            sample(s, acid, samples)
            rec = s.view.flight(slot)
            done[key] = (samples, rec.origin, rec.destination, rec.scheduled_arrival_s)

    def every(s: Simulation) -> None:
        for acid, (_, samples) in live.items():
            sample(s, acid, samples)

    probe.hooks.created.add(created, name="probe.created")
    probe.hooks.deleted.add(deleted, name="probe.deleted")
    probe.hooks.post_step.add(every, interval_s=sample_s, name="probe.sample")
    while not probe.is_quiescent() and probe.simt < limit_s:
        probe.run_until(min(probe.simt + 600.0, limit_s))
    for acid, (key, samples) in list(live.items()):  # still flying at the limit: the intent ends there
        sample(probe, acid, samples)
        rec = probe.view.flight(probe.view.slot(acid))
        done[key] = (samples, rec.origin, rec.destination, rec.scheduled_arrival_s)
    out: dict[str, Intent] = {}
    for key, (samples, orig, dest, arrival_s) in done.items():
        arr = np.array(samples)
        keep = np.concatenate([[True], np.diff(arr[:, 0]) > 1e-9])  # creation/deletion on a sample instant
        arr = arr[keep]
        out[key] = Intent(arr[:, 0] - arr[0, 0], arr[:, 1], arr[:, 2], float(arr[0, 3]), orig, dest, filed[key],
                          arrival_s)
    return out


@dataclass(frozen=True)
class Frame:
    """A local east/north frame [m] (equirectangular about a reference point: a city's extent)."""

    lat0: float
    lon0: float

    def xy(self, lat: np.ndarray, lon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.radians((np.asarray(lon) - self.lon0 + 180.0) % 360.0 - 180.0) * R_EARTH_M * math.cos(
            math.radians(self.lat0))
        y = np.radians(np.asarray(lat) - self.lat0) * R_EARTH_M
        return x, y


@dataclass
class Reservation:
    key: str
    depart_s: float
    alt_m: float
    k0: int  # first grid index
    x: np.ndarray  # east [m] at grid indices k0, k0 + 1, ...
    y: np.ndarray

    @property
    def k1(self) -> int:  # last grid index
        return self.k0 + len(self.x) - 1


@dataclass
class IntentTable:
    """The planned flights' intents on a time grid, and conflict checks of candidates (module docstring)."""

    frame: Frame
    grid_s: float = 5.0
    separation_m: float = field(default_factory=lambda: PAPER_STANDARD.lowc_horizontal_m)  # the paper's LoWC
    reserved: list[Reservation] = field(default_factory=list)
    _local: dict[int, tuple[Intent, np.ndarray, np.ndarray]] = field(default_factory=dict)

    def local(self, intent: Intent) -> tuple[np.ndarray, np.ndarray]:
        """An intent's samples in the local frame [m] (computed once per intent)."""
        got = self._local.get(id(intent))
        if got is None or got[0] is not intent:
            x, y = self.frame.xy(intent.lat, intent.lon)
            got = self._local[id(intent)] = (intent, x, y)
        return got[1], got[2]

    def on_grid(self, intent: Intent, depart_s: float) -> tuple[int, np.ndarray, np.ndarray]:
        """First grid index and east/north positions at the grid instants the flight spans.

        One instant more at each end, holding the first and last positions: the
        flight then covers its whole time (it departs and ends between grid
        instants), as if it occupied its vertiports up to a grid step longer.
        """
        g = self.grid_s
        k0 = math.ceil(depart_s / g - 1e-9) - 1
        k1 = math.floor((depart_s + intent.duration_s) / g + 1e-9) + 1
        t = np.arange(k0, max(k1, k0 - 1) + 1) * g - depart_s
        x, y = self.local(intent)
        return k0, np.interp(t, intent.t_rel, x), np.interp(t, intent.t_rel, y)

    def reserve(self, key: str, intent: Intent, depart_s: float, alt_m: float) -> None:
        k0, x, y = self.on_grid(intent, depart_s)
        self.reserved.append(Reservation(key, depart_s, alt_m, k0, x, y))

    def candidates(self, intents: Sequence[Intent], request_s: float, shifts: int, step: int,
                   alts_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Conflicts of departing at ``request_s + d * step * grid_s`` (d < shifts) on each layer.

        ``intents[l]`` is the flight as flown at ``alts_m[l]``. Returns
        ``(conflicts, closest)``, both ``(shifts, len(alts_m))``: the number of
        reserved flights the candidate would conflict with, and the smallest
        predicted 3-D distance to any of them [m] (inf when none shares its time).
        """
        nl = len(alts_m)
        conflicts = np.zeros((shifts, nl), np.int64)
        closest = np.full((shifts, nl), np.inf)
        grids = [self.on_grid(i, request_s) for i in intents]
        k0 = grids[0][0]  # the same for every layer: it depends on the departure time only
        m = max(len(g[1]) for g in grids)
        if m == 0 or not self.reserved:
            return conflicts, closest
        lo, hi = k0, k0 + (shifts - 1) * step + m - 1  # grid window every candidate lies in
        near = [r for r in self.reserved if r.k1 >= lo and r.k0 <= hi]  # a scan: a few hundred flights a day
        if not near:
            return conflicts, closest
        w = hi - lo + 1
        rx = np.full((w, len(near)), np.nan)
        ry = np.full((w, len(near)), np.nan)
        for j, r in enumerate(near):
            a, b = max(r.k0, lo), min(r.k1, hi)
            rx[a - lo: b - lo + 1, j] = r.x[a - r.k0: b - r.k0 + 1]
            ry[a - lo: b - lo + 1, j] = r.y[a - r.k0: b - r.k0 + 1]
        ralt = np.array([r.alt_m for r in near])
        for layer, (_, px, py) in enumerate(grids):
            rows = (np.arange(shifts) * step)[:, None] + np.arange(len(px))[None, :]  # (shifts, m) window rows
            h2 = _segment_min_sq(px[None, :, None] - rx[rows], py[None, :, None] - ry[rows])  # (shifts, seg, J)
            h2min = np.where(np.isnan(h2), np.inf, h2).min(axis=1)  # (shifts, J); the altitudes are constant
            d2 = h2min + (alts_m[layer] - ralt[None, :]) ** 2
            conflicts[:, layer] = (d2 < self.separation_m ** 2).sum(axis=1)
            closest[:, layer] = np.sqrt(d2.min(axis=1))
        return conflicts, closest


def _segment_min_sq(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """Smallest squared horizontal distance on each grid interval (linear relative motion), and at each
    grid instant, along axis 1; NaN where a flight is absent."""
    points = dx ** 2 + dy ** 2
    if dx.shape[1] < 2:
        return points
    ax, ay = dx[:, :-1], dy[:, :-1]
    ux, uy = dx[:, 1:] - ax, dy[:, 1:] - ay
    uu = ux * ux + uy * uy
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.clip(-(ax * ux + ay * uy) / np.where(uu > 0, uu, 1.0), 0.0, 1.0)
    cx, cy = ax + s * ux, ay + s * uy
    return np.concatenate([cx * cx + cy * cy, points], axis=1)
