"""The public simulator API: read traffic through a view, change it through intents (docs/api.md).

:class:`aamsim.Simulation` inherits :class:`SimulationAPI`, so a use case, a
baseline or a plugin writes::

    view = sim.view                      # read-only named arrays, SI units
    slots = sim.slots(["UAM1", "UAM2"])
    sim.select_speed(slots, 30.0)        # CAS 30 m/s for both, VNAV speed off
    sim.select_altitude("UAM1", 300.0)
    sim.direct_to("UAM1", "WP3")

Targets are a callsign, a slot (int), a list of callsigns or an int array of
slots. The stack commands (SPD, ALT, HDG, ...) call the same methods, so a
change made here and one made by a scenario line are the same change.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.errors import CommandError
from aamsim.simapi import Target
from aamsim.traffic import intents
from aamsim.traffic.view import PUBLIC_FLAGS, PUBLIC_FLOATS, TrafficView
from aamsim.units import Speed

if TYPE_CHECKING:
    from aamsim.conflicts.separation import SeparationStandard
    from aamsim.services import Services
    from aamsim.traffic.route import Route
    from aamsim.traffic.traffic import FlightRecord, Traffic
    from aamsim.traffic.wind import WindField


__all__ = ["PUBLIC_FLAGS", "PUBLIC_FLOATS", "SimulationAPI", "Target", "TrafficView"]


class SimulationAPI:
    """Views and intents of a simulation (mixed into :class:`aamsim.Simulation`)."""

    _traffic: Traffic
    _wind: WindField
    _traffic_view: TrafficView
    flight_log: list[FlightRecord]
    # Built-in services (conflict detection, metrics, ...), built by the constructor (aamsim.services).
    services: Services
    create_aircraft: Callable[..., int]
    delete_aircraft: Callable[..., FlightRecord]

    @property
    def separation_standard(self) -> SeparationStandard:
        """The NMAC and LoWC volumes [m] that events, metrics, use cases and baselines count against.

        The conflict service owns it (:attr:`aamsim.conflicts.ConflictService.standard`; ``SEPVOLUME``
        changes it).
        """
        return self.services.conflicts.standard

    def set_separation_standard(self, standard: SeparationStandard) -> None:
        """Count NMAC and LoWC events against ``standard`` from now on (the conflict service's volumes).

        Like ``SEPVOLUME``, it starts the services (conflict detection runs from the next check on).
        """
        self.services.start().conflicts.set_standard(standard)

    def flights(self, real_traffic: bool = False) -> Iterator[FlightRecord]:
        """Closed flights followed by the open ones (their distance and times brought up to date).

        The AAM flights; with ``real_traffic`` the replayed real aircraft instead (their records
        say ``real_traffic``), so that flight metrics and ``flights.csv`` count AAM flights only.
        """
        yield from (rec for rec in self.flight_log if rec.real_traffic == real_traffic)
        view = self.view
        for i, rec in enumerate(self._traffic.flights):
            if rec.real_traffic != real_traffic:
                continue
            rec.distance_m = float(view.distflown[i])
            rec.airborne_s = float(view.airborne_s[i])
            rec.slow_s = float(view.slow_s[i])
            yield rec

    # ------------------------------------------------------------------ reading
    @property
    def view(self) -> TrafficView:
        """Read-only named arrays of the live aircraft (``view.lat``, ``view.ids``, ...)."""
        try:
            view: TrafficView = self._traffic_view
            if view._traffic is self._traffic:
                return view
        except AttributeError:
            pass
        view = self._traffic_view = TrafficView(self._traffic)
        return view

    def slot(self, acid: str | int) -> int:
        """Slot of one aircraft (a callsign, or a slot checked to be live)."""
        if isinstance(acid, (int, np.integer)):
            if not 0 <= int(acid) < self._traffic.n:
                raise IndexError(f"no aircraft in slot {acid}")
            return int(acid)
        return self._traffic.index(acid)

    def slots(self, targets: Target) -> np.ndarray:
        """Slots of one or more aircraft as an int64 array."""
        if isinstance(targets, np.ndarray) and targets.dtype.kind in "iu":
            return targets.astype(np.int64, copy=False)
        if isinstance(targets, (str, int, np.integer)):
            return np.array([self.slot(targets)], dtype=np.int64)
        return np.fromiter((self.slot(a) for a in targets), dtype=np.int64, count=len(targets))

    def _advisable(self, slots: np.ndarray) -> np.ndarray:
        """``slots`` unless one is real traffic replayed from a recording, which takes no intents."""
        refused = slots[self.view.noncooperative[slots]] if len(slots) else slots
        if len(refused):
            names = ", ".join(self._traffic.ids[int(s)] for s in refused[:5]) + (" ..." if len(refused) > 5 else "")
            raise CommandError(f"{names}: real traffic replayed from a recording (non-cooperative): it takes no "
                               "advisories or intents; only DEL removes it")
        return slots

    def _intent_slot(self, target: str | int) -> int:
        slot = self.slot(target)
        self._advisable(np.array([slot], dtype=np.int64))
        return slot

    def _intent_slots(self, targets: Target) -> np.ndarray:
        return self._advisable(self.slots(targets))

    # ------------------------------------------------------------------ intents
    def select_speed(self, targets: Target, speed: Speed | float | np.ndarray) -> None:
        """Select a speed: a :class:`~aamsim.units.Speed` (CAS m/s or Mach) or CAS [m/s] per target.

        VNAV speed control goes off, as with BlueSky's SPD.
        """
        slots = self._intent_slots(targets)
        if isinstance(speed, Speed):
            intents.select_speed(self._traffic, slots, speed.value, speed.is_mach)
        else:
            intents.select_speed(self._traffic, slots, speed)

    def hold_speed(self, targets: Target) -> None:
        """Select each target's current CAS (a "maintain speed" advisory)."""
        slots = self._intent_slots(targets)
        intents.select_speed(self._traffic, slots, self.view.cas[slots])

    def select_altitude(self, target: str | int, altitude_m: float, vs_mps: float | None = None) -> None:
        """Select an altitude [m], optionally a vertical speed [m/s]; VNAV off (BlueSky's ALT)."""
        intents.select_altitude(self._traffic, self._intent_slot(target), altitude_m, vs_mps)

    def select_vertical_speed(self, target: str | int, vs_mps: float) -> None:
        """Select a vertical speed [m/s]; VNAV off (BlueSky's VS)."""
        intents.select_vertical_speed(self._traffic, self._intent_slot(target), vs_mps)

    def select_heading(self, target: str | int, heading_deg: float) -> None:
        """Fly a heading [deg true]; LNAV off (BlueSky's HDG)."""
        intents.select_heading(self._traffic, self._intent_slot(target), heading_deg, self._wind)

    def command_resolution(self, targets: Target, trk_deg: float | np.ndarray, gs_mps: float | np.ndarray,
                           vs_mps: float | np.ndarray, alt_m: float | np.ndarray) -> None:
        """A conflict resolution's track [deg], ground speed [m/s], vertical speed [m/s] and altitude [m].

        Flown, within the envelope, by the targets that follow the resolution (:meth:`follow_resolution`)
        instead of the autopilot's commands, as BlueSky's ASAS; the autopilot keeps its own.
        """
        intents.command_resolution(self._traffic, self._intent_slots(targets), trk_deg, gs_mps, vs_mps, alt_m)

    def follow_resolution(self, targets: Target, on: bool | np.ndarray) -> None:
        """Fly the resolution's commands (on) or the autopilot's again (off); see :meth:`command_resolution`."""
        intents.follow_resolution(self._traffic, self._intent_slots(targets), on)

    def set_cruise_speed(self, target: str | int, cas_mps: float) -> None:
        """CAS [m/s] selected when a fly-turn ends and the new leg has no speed constraint (CRUISESPD)."""
        intents.set_cruise_speed(self._traffic, self._intent_slot(target), cas_mps)

    def set_bank(self, target: str | int, bank_rad: float) -> None:
        """Bank angle used in turns [rad], in (0, pi/2)."""
        if not 0.0 < bank_rad < np.pi / 2:
            raise ValueError(f"bank angle must be between 0 and 90 deg, not {np.degrees(bank_rad):g}")
        intents.set_bank(self._traffic, self._intent_slot(target), bank_rad)

    def move(self, target: str | int, lat: float, lon: float, alt_m: float | None = None,
             hdg_deg: float | None = None, speed: Speed | None = None, vs_mps: float | None = None) -> None:
        """Put an aircraft somewhere else (BlueSky's MOVE)."""
        intents.move(self._traffic, self._intent_slot(target), lat, lon, alt_m, hdg_deg,
                     None if speed is None else speed.value, bool(speed and speed.is_mach), vs_mps)

    def displace(self, targets: Target, dnorth_m: np.ndarray, deast_m: np.ndarray, dalt_m: np.ndarray) -> None:
        """Move aircraft by small offsets [m] north, east and up, speeds unchanged (turbulence)."""
        intents.displace(self._traffic, self.slots(targets), dnorth_m, deast_m, dalt_m)

    def offset_altitude(self, targets: Target, dz_m: float | np.ndarray) -> None:
        """Shift aircraft and their selected altitude by ``dz_m`` [m]."""
        intents.offset_altitude(self._traffic, self._intent_slots(targets), dz_m)

    def direct_to(self, target: str | int, waypoint: str | int) -> None:
        """Fly straight to a waypoint of the route (by name or index); LNAV on."""
        slot = self._intent_slot(target)
        route = self._traffic.routes[slot]
        index = route.find(waypoint) if isinstance(waypoint, str) else int(waypoint)
        if not 0 <= index < len(route):
            raise CommandError(f"{self._traffic.ids[slot]} has no waypoint {waypoint} in its route")
        intents.direct_to(self._traffic, slot, index)

    def edit_route(self, slot: int) -> Route:
        """The aircraft's route, to be changed in place (ADDWPT, DELWPT, ...); see :meth:`activate_waypoint`."""
        return self._traffic.routes[self._intent_slot(slot)]

    def activate_waypoint(self, slot: int, index: int) -> None:
        """Make waypoint ``index`` of the route the active one (guidance follows it from the next step)."""
        intents.activate_waypoint(self._traffic, self._intent_slot(slot), index)

    def flight_record(self, slot: int) -> FlightRecord:
        """The aircraft's flight record, to be annotated (DEST, ORIG, RTA)."""
        return self._traffic.flights[self._intent_slot(slot)]

    def set_navigation(self, target: str | int, lnav: bool | None = None, vnav: bool | None = None,
                       vnav_speed: bool | None = None) -> None:
        """Switch LNAV / VNAV / VNAV speed control (None: unchanged); no route checks (see LNAV, VNAV)."""
        intents.set_navigation(self._traffic, self._intent_slot(target), lnav, vnav, vnav_speed)

    def resume_route(self, target: str | int) -> None:
        """LNAV on towards the nearest waypoint of the route (BlueSky's LNAV ON)."""
        intents.resume_route(self._traffic, self._intent_slot(target))

    def engage_vnav(self, target: str | int) -> None:
        """VNAV on along the route's altitude and speed constraints (BlueSky's VNAV ON)."""
        intents.engage_vnav(self._traffic, self._intent_slot(target))

    def set_climb_profile(self, target: str | int, early_climb: bool | None = None,
                          late_descent: bool | None = None) -> None:
        """BlueSky's SWTOC / SWTOD switches (None: unchanged)."""
        intents.set_climb_profile(self._traffic, self._intent_slot(target), early_climb, late_descent)

    def set_replay_state(self, targets: Target, lat: np.ndarray, lon: np.ndarray, alt_m: np.ndarray,
                         gsnorth_mps: np.ndarray, gseast_mps: np.ndarray, vs_mps: np.ndarray) -> None:
        """Put replayed real aircraft at a recorded state (SI; velocity north/east/up [m/s]).

        Only for non-cooperative aircraft (created with ``noncooperative=True``): the kernel flies
        them straight at this velocity until the next call.
        """
        slots = self.slots(targets)
        if len(slots) and not self.view.noncooperative[slots].all():
            raise CommandError("set_replay_state: only replayed (non-cooperative) aircraft follow a recording")
        intents.set_replay_state(self._traffic, slots, lat, lon, alt_m, gsnorth_mps, gseast_mps, vs_mps)

    def set_kinematic_state(self, targets: Target, values: dict[str, np.ndarray]) -> None:
        """Overwrite position, speeds and directions of ``targets`` from another simulator's state.

        ``values``: one array per name of :data:`aamsim.traffic.intents.SYNC_FIELDS` (SI), one entry per
        target. The caches that depend on them are invalidated, so the next step recomputes them; the
        BlueSky backend mirrors BlueSky's aircraft this way after each of its steps.
        """
        intents.set_kinematic_state(self._traffic, self.slots(targets), values)

    def overwrite_state(self, targets: Target, name: str, values: float | bool | np.ndarray) -> None:
        """Set one field directly, as BlueSky's ``traf.alt[i] = x`` does: no mode switch, no other effect.

        ``name`` is a public field (``alt``, ``hdg``, ``selalt``, ``selvs``, ``ap_trk``, ``vnav``, ...:
        :data:`aamsim.traffic.intents.OVERWRITABLE_FLOATS` and ``OVERWRITABLE_FLAGS``). Prefer the
        intents above; this is the way BlueSky code that writes the state arrays runs on aamsim
        (:mod:`aamsim.compat.bluesky`).
        """
        slots = self._intent_slots(targets)
        intents.overwrite_state(self._traffic, slots, name, np.broadcast_to(values, slots.shape))

    def create(self, acid: str, actype: str, lat: float, lon: float, hdg_deg: float = 0.0, alt_m: float = 0.0,
               speed: Speed | float = 0.0) -> int:
        """Create an aircraft (CAS [m/s] or a :class:`~aamsim.units.Speed`); returns its slot."""
        spd = speed if isinstance(speed, Speed) else Speed(float(speed))
        return self.create_aircraft(acid, actype, lat, lon, hdg_deg, alt_m, spd)

    def delete(self, targets: Target) -> None:
        """Delete aircraft (not counted as arrivals unless they are at their destination)."""
        names = [self._traffic.ids[s] for s in self.slots(targets).tolist()]
        for name in names:  # by callsign: deleting moves the last aircraft into the freed slot
            self.delete_aircraft(self._traffic.index(name))

    # ------------------------------------------------------------------ wind
    def wind_at(self, lat: float, lon: float, alt_m: float) -> tuple[float, float]:
        """North and east wind [m/s] at a position [deg] and altitude [m] (0, 0 without wind)."""
        vn, ve = self._wind.get(lat, lon, alt_m)
        return float(vn), float(ve)

    def add_wind_point(self, lat: float, lon: float, direction_deg: float, speed_mps: float) -> None:
        """Wind at a point [deg], the same at every altitude: the direction it blows from [deg], speed [m/s]."""
        self._wind.add_point(lat, lon, direction_deg, speed_mps)

    def add_wind_profile(self, lat: float, lon: float, alts_m: np.ndarray, directions_deg: np.ndarray,
                         speeds_mps: np.ndarray) -> None:
        """Wind at a point [deg] by altitude [m]: direction it blows from [deg] and speed [m/s] per altitude."""
        self._wind.add_profile(lat, lon, alts_m, directions_deg, speeds_mps)

    def clear_wind(self) -> None:
        """Remove every wind point (``DEL WIND``)."""
        self._wind.clear()

    def describe(self) -> dict[str, Any]:
        """The public fields and what they mean (for documentation and tools)."""
        return {"floats": dict(PUBLIC_FLOATS), "flags": dict(PUBLIC_FLAGS)}
