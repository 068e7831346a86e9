"""Aircraft state as a struct of arrays, indexed by slot.

``F[field, slot]`` holds the float state and ``B[field, slot]`` the switches
(see :mod:`aamsim.traffic.fields`); slots ``0..n-1`` are live. Creating an
aircraft appends a slot (the arrays double when full); deleting one moves
the last aircraft into the freed slot, so both are O(1) in the number of
aircraft. The callsign -> slot map is the only way to find an aircraft:
slots move, callsigns do not.

The arrays may be a block of a :class:`~aamsim.traffic.pool.TrafficPool`, the
storage that several simulations share so that one kernel call steps them all;
the pool then grows them (every block at once).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from aamsim import aero
from aamsim.errors import UnknownAircraft
from aamsim.traffic import fields as f
from aamsim.traffic.performance import Envelope
from aamsim.traffic.route import Route
from aamsim.units import FPM, Speed

# The step kernel's per-slot working arrays: guidance bearing [deg] and distance [m] computed by
# the waypoint test, whether they are this step's ("fresh"), and whether the waypoint is reached.
Scratch = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


class BlockStorage(Protocol):
    """Shared storage a :class:`Traffic` can be a block of (:class:`~aamsim.traffic.pool.TrafficPool`).

    Declared here, not imported from the pool, so that this module does not depend on the pool that
    depends on it (the import graph of ``aamsim`` has no cycle, issue 29).
    """

    def bind(self, traffic: Traffic) -> None:
        """Give ``traffic`` its block's arrays and capacity."""

    def grow(self) -> None:
        """Double every block, this traffic's included."""


def new_state_arrays(capacity: int) -> tuple[np.ndarray, np.ndarray, Scratch]:
    """Zeroed float and flag matrices (Fortran order: one aircraft's fields together) and kernel scratch."""
    F = np.zeros((f.N_FLOAT, capacity), order="F")
    B = np.zeros((f.N_BOOL, capacity), dtype=np.bool_, order="F")
    scratch = (np.zeros(capacity), np.zeros(capacity), np.zeros(capacity, dtype=np.bool_),
               np.zeros(capacity, dtype=np.bool_))
    return F, B, scratch

PERF_DEFAULT_AXMAX = 2.0  # m/s^2 until the first performance refresh (BlueSky's PerfBase default)
# Distance to the active waypoint before guidance first runs. BlueSky starts it
# at -999 m and VNAV plans a leg activated in the creation step with it; kept
# so that such scenarios climb exactly as in BlueSky.
INITIAL_GUIDANCE_DISTANCE = -999.0


@dataclass
class FlightRecord:
    """Book-keeping of one flight, closed when the aircraft is deleted."""

    acid: str
    actype: str
    created_s: float
    origin: str = ""
    destination: str = ""
    dest_lat: float = math.nan
    dest_lon: float = math.nan
    scheduled_arrival_s: float = math.nan
    deleted_s: float = math.nan
    arrived: bool = False
    distance_m: float = 0.0
    airborne_s: float = 0.0
    slow_s: float = 0.0
    advisories: int = 0
    last_advisory: str = ""  # the latest advisory's action and sim time (what a viewer shows on hover)
    real_traffic: bool = False  # a replayed real aircraft (aamsim.realtraffic.replay), not an AAM flight


# State that must stay finite: the rows from lat to vs (position, altitude, heading, track, speeds,
# vertical speed). The kernel sums position, altitude and TAS after each step (every other row feeds
# them within the step) and stops with STATUS_NONFINITE when the sum is not finite; these rows then
# name the aircraft and describe their state.
_FINITE = slice(f.LAT, f.VS + 1)
_FINITE_NAMES = f.FLOAT_FIELDS[f.LAT : f.VS + 1]


# Rows of the fixed-wing model and the envelope fields they are copied from (see aamsim.traffic.openap).
_OPENAP_ROWS = (
    (f.FW_MASS, "mass_kg"), (f.FW_WING_AREA, "wing_area_m2"), (f.FW_MAX_THRUST, "max_thrust_n"),
    (f.FW_CD0_CLEAN, "cd0_clean"), (f.FW_K_CLEAN, "k_clean"),
    (f.FW_CD0_TAKEOFF, "cd0_takeoff"), (f.FW_K_TAKEOFF, "k_takeoff"), (f.FW_CD0_LANDING, "cd0_landing"),
    (f.FW_K_LANDING, "k_landing"), (f.FW_VMINTO, "vminto_mps"),
    (f.FW_VMAXIC, "vmaxic_mps"), (f.FW_VMINAP, "vminap_mps"), (f.FW_VMAXAP, "vmaxap_mps"),
)


def _set_openap_rows(F: np.ndarray, i: int, envelope: Envelope) -> None:
    """The fixed-wing model's coefficients of slot ``i`` (NaN when the type has none)."""
    coefficients = envelope.openap
    for row, name in _OPENAP_ROWS:
        F[row, i] = math.nan if coefficients is None else getattr(coefficients, name)
    # The en-route range is the envelope's (what the aircraft is created with).
    F[f.FW_VMINER, i] = math.nan if coefficients is None else envelope.vmin_mps
    F[f.FW_VMAXER, i] = math.nan if coefficients is None else envelope.vmax_mps
    F[f.PHASE, i] = 0.0  # unknown until the first refresh
    F[f.TAKEOFF_TAS, i] = math.nan


@dataclass
class Traffic:
    """All aircraft of one simulation."""

    capacity: int = 64
    n: int = 0
    layout_version: int = 0  # changes whenever an aircraft is created or deleted (slots move) or the arrays grow
    turn_speeds_used: bool = False  # some route has had a fly-turn waypoint (the kernel's turn-speed part runs)
    resolution_used: bool = False  # some aircraft follows a conflict resolution (the kernel's ASAS part runs)
    F: np.ndarray = field(init=False, repr=False)
    B: np.ndarray = field(init=False, repr=False)
    scratch: Scratch = field(init=False, repr=False)  # the step kernel's working arrays, per slot
    pool: BlockStorage | None = field(default=None, repr=False)  # shared storage this traffic is a block of
    world: int = 0  # its block in the pool
    ids: list[str] = field(default_factory=list)
    types: list[str] = field(default_factory=list)
    routes: list[Route] = field(default_factory=list)
    flights: list[FlightRecord] = field(default_factory=list)
    _index: dict[str, int] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if self.pool is not None:
            self.pool.bind(self)  # sets the arrays and the capacity
        else:
            self.F, self.B, self.scratch = new_state_arrays(self.capacity)

    # ------------------------------------------------------------------ access
    def __len__(self) -> int:
        return self.n

    def __contains__(self, acid: object) -> bool:
        return isinstance(acid, str) and acid.upper() in self._index

    def index(self, acid: str) -> int:
        """Slot of a callsign; raises :class:`UnknownAircraft`."""
        try:
            return self._index[acid.upper()]
        except KeyError:
            raise UnknownAircraft(acid.upper()) from None

    def find(self, acid: str) -> int | None:
        """Slot of a callsign, or None."""
        return self._index.get(acid.upper())

    def field(self, row: int) -> np.ndarray:
        """Writable view of one float field over the live slots."""
        return self.F[row, : self.n]

    def flag(self, row: int) -> np.ndarray:
        """Writable view of one boolean field over the live slots."""
        return self.B[row, : self.n]

    def __iter__(self) -> Iterator[str]:
        return iter(list(self.ids))

    # Named views of the fields users read most.
    def non_finite_slots(self) -> list[int]:
        """Slots whose position, altitude, speeds, heading or vertical speed are not finite."""
        return np.flatnonzero(~np.isfinite(self.F[_FINITE, : self.n]).all(axis=0)).tolist()

    def describe_state(self, i: int) -> str:
        """``lat .., lon .., alt .., ...`` of slot ``i`` (SI units, as the field names say), for messages."""
        return ", ".join(f"{name} {value:.6g}" for name, value in zip(_FINITE_NAMES, self.F[_FINITE, i]))

    lat = property(lambda self: self.F[f.LAT, : self.n])
    lon = property(lambda self: self.F[f.LON, : self.n])
    alt = property(lambda self: self.F[f.ALT, : self.n])
    hdg = property(lambda self: self.F[f.HDG, : self.n])
    trk = property(lambda self: self.F[f.TRK, : self.n])
    tas = property(lambda self: self.F[f.TAS, : self.n])
    cas = property(lambda self: self.F[f.CAS, : self.n])
    gs = property(lambda self: self.F[f.GS, : self.n])
    gsnorth = property(lambda self: self.F[f.GSNORTH, : self.n])
    gseast = property(lambda self: self.F[f.GSEAST, : self.n])
    vs = property(lambda self: self.F[f.VS, : self.n])
    ax = property(lambda self: self.F[f.AX, : self.n])

    # --------------------------------------------------------------- lifecycle
    def _grow(self) -> None:
        if self.pool is not None:
            self.pool.grow()  # every block of the pool, this one included
            return
        new_cap = self.capacity * 2
        F, B, scratch = new_state_arrays(new_cap)
        self.adopt(F, B, scratch, new_cap)

    def adopt(self, F: np.ndarray, B: np.ndarray, scratch: Scratch, capacity: int) -> None:
        """Move the live aircraft's state into new arrays of ``capacity`` slots (growth, a pool's blocks)."""
        n = self.n
        if F is not self.F:
            F[:, :n] = self.F[:, :n]
            B[:, :n] = self.B[:, :n]
            for new, old in zip(scratch, self.scratch):
                new[:n] = old[:n]
        self.F, self.B, self.scratch, self.capacity = F, B, scratch, capacity
        self.layout_version += 1  # the arrays are new: views of the old ones are stale

    def detach(self) -> None:
        """Leave the pool: keep a private copy of the state (the block goes to another simulation)."""
        if self.pool is None:
            return
        F, B, scratch = new_state_arrays(self.capacity)
        self.adopt(F, B, scratch, self.capacity)
        self.pool = None

    def create(
        self,
        acid: str,
        actype: str,
        envelope: Envelope,
        lat: float,
        lon: float,
        hdg: float,
        alt: float,
        spd: Speed,
        simt: float,
        noncooperative: bool = False,
    ) -> int:
        """Add one aircraft; returns its slot. The caller checks the callsign is free.

        ``noncooperative``: real traffic replayed from a recording (the kernel flies it straight
        at the velocity the replay sets; intents refuse it).
        """
        acid = acid.upper()
        if self.n == self.capacity:
            self._grow()
        i = self.n
        self.n += 1
        self.layout_version += 1
        F, B = self.F, self.B
        F[:, i] = 0.0
        B[:, i] = False
        lon = (lon + 180.0) % 360.0 - 180.0 if abs(lon) > 180.0 else lon
        if spd.is_mach:
            tas = float(aero.mach2tas(spd.value, alt))
            cas = float(aero.tas2cas(tas, alt))
        else:
            cas = spd.value
            tas = float(aero.cas2tas(cas, alt))
        hdg = hdg % 360.0
        F[f.LAT, i] = lat
        F[f.LON, i] = lon
        F[f.ALT, i] = alt
        F[f.HDG, i] = hdg
        F[f.TRK, i] = hdg
        F[f.TAS, i] = tas
        F[f.CAS, i] = cas
        F[f.MACH, i] = float(aero.tas2mach(tas, alt))
        F[f.GS, i] = tas
        F[f.GSNORTH, i] = tas * math.cos(math.radians(hdg))
        F[f.GSEAST, i] = tas * math.sin(math.radians(hdg))
        F[f.COSLAT, i] = math.cos(math.radians(lat))
        F[f.CREATED_S, i] = simt
        # Autopilot holds what it was created with (BlueSky: selspd = CAS).
        F[f.SELSPD, i] = cas
        F[f.SELALT, i] = alt
        F[f.AP_TRK, i] = hdg
        F[f.AP_TAS, i] = tas
        F[f.AP_ALT, i] = alt
        F[f.BANKDEF, i] = envelope.bank_rad
        F[f.VSDEF, i] = 1500.0 * FPM
        F[f.DIST2VS, i] = -math.inf
        F[f.DIST2WP, i] = INITIAL_GUIDANCE_DISTANCE
        # Envelope; axmax takes the type's value at the next performance refresh.
        F[f.VMIN, i] = envelope.vmin_mps
        F[f.VMAX, i] = envelope.vmax_mps
        F[f.VSMIN, i] = envelope.vsmin_mps
        F[f.VSMAX, i] = envelope.vsmax_mps
        F[f.HMAX, i] = envelope.hmax_m
        F[f.AXMAX_TYPE, i] = envelope.axmax_mps2
        F[f.AXMAX, i] = PERF_DEFAULT_AXMAX if envelope.rotor else envelope.axmax_mps2
        F[f.MMO, i] = envelope.mmo
        B[f.B_ROTOR, i] = envelope.rotor
        _set_openap_rows(F, i, envelope)
        # No active leg yet.
        for row in (f.WP_NEXTALTCO, f.WP_NEXTSPD, f.WP_SPD, f.WP_SPDCON, f.WP_NEXTQDR, f.WP_CURLEGDIR,
                    f.WP_TURNSPD, f.WP_OLDTURNSPD, f.WP_NEXTTURNSPD, f.WP_NEXTTURNRAD, f.CRUISESPD):
            F[row, i] = math.nan
        F[f.WP_TURNDIST, i] = 1.0
        B[f.B_WP_FLYBY, i] = True
        B[f.B_SWTOC, i] = True
        B[f.B_SWTOD, i] = True
        B[f.B_NONCOOP, i] = noncooperative
        # Caches start invalid.
        for row in (f.C_ALT, f.C_HDG, f.C_TAS_IN, f.C_SPD_IN, f.C_WPLAT, f.C_BANK, f.C_LAT, f.C_LA0, f.C_Q0):
            F[row, i] = math.nan
        self.ids.append(acid)
        self.types.append(actype.upper())
        self.routes.append(Route(acid))
        self.flights.append(FlightRecord(acid, actype.upper(), simt, real_traffic=noncooperative))
        self._index[acid] = i
        return i

    def delete(self, i: int) -> FlightRecord:
        """Remove the aircraft in slot ``i``; the last aircraft takes its slot.

        Returns the aircraft's flight record (not yet closed: the caller sets
        deletion time and arrival).
        """
        if not 0 <= i < self.n:
            raise IndexError(f"no aircraft in slot {i}")
        last = self.n - 1
        record = self.flights[i]
        record.distance_m = float(self.F[f.DISTFLOWN, i])
        record.airborne_s = float(self.F[f.AIRBORNE_S, i])
        record.slow_s = float(self.F[f.SLOW_S, i])
        del self._index[self.ids[i]]
        if i != last:
            self.F[:, i] = self.F[:, last]
            self.B[:, i] = self.B[:, last]
            self.ids[i], self.types[i] = self.ids[last], self.types[last]
            self.routes[i], self.flights[i] = self.routes[last], self.flights[last]
            self._index[self.ids[i]] = i
        for seq in (self.ids, self.types, self.routes, self.flights):
            seq.pop()  # type: ignore[attr-defined]
        self.n -= 1
        self.layout_version += 1
        return record

    def clear(self) -> list[FlightRecord]:
        """Delete every aircraft; returns their flight records."""
        records = []
        while self.n:
            records.append(self.delete(self.n - 1))
        return records
