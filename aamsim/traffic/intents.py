"""Intents: the one place that turns "what an aircraft should do" into writes to the state arrays.

Stack commands, use cases, baselines and plugins change aircraft through these
functions (usually via the :class:`aamsim.api.SimulationAPI` methods of the
simulation), never by writing the field matrices themselves. Every function
takes slots (an int or an int array, so that a use case can advise hundreds of
aircraft in one call) and SI values: m, m/s, degrees.
"""

from __future__ import annotations

import math

import numpy as np

from aamsim import aero
from aamsim.traffic import fields as f
from aamsim.traffic import openap
from aamsim.traffic.autopilot import activate_waypoint, compute_vnav, nearest_active_index
from aamsim.traffic.traffic import Traffic
from aamsim.traffic.wind import APPLY_ABOVE_M, WindField
from aamsim.units import R_EARTH

Slots = int | np.ndarray


def select_speed(traffic: Traffic, slots: Slots, value: float | np.ndarray, is_mach: bool = False) -> None:
    """Select a speed (CAS m/s, or Mach when ``is_mach``); VNAV speed control off (BlueSky's SPD)."""
    traffic.F[f.SELSPD, slots] = value
    traffic.B[f.B_SELSPD_MACH, slots] = is_mach
    traffic.B[f.B_SWVNAVSPD, slots] = False


def select_altitude(traffic: Traffic, slot: int, altitude_m: float, vs_mps: float | None = None) -> None:
    """Select an altitude, optionally a vertical speed; VNAV off (BlueSky's ALT).

    Without a vertical speed, a previously selected one pointing the other way
    is dropped in favour of the default.
    """
    F = traffic.F
    F[f.SELALT, slot] = altitude_m
    traffic.B[f.B_SWVNAV, slot] = False
    if vs_mps:
        F[f.SELVS, slot] = vs_mps
    else:
        selvs = F[f.SELVS, slot]
        if selvs * (altitude_m - F[f.ALT, slot]) < 0.0 and abs(selvs) > 0.01:
            F[f.SELVS, slot] = 0.0


def select_vertical_speed(traffic: Traffic, slot: int, vs_mps: float) -> None:
    """Select a vertical speed, used while the selected altitude differs; VNAV off (BlueSky's VS)."""
    traffic.F[f.SELVS, slot] = vs_mps
    traffic.B[f.B_SWVNAV, slot] = False


def select_heading(traffic: Traffic, slot: int, heading_deg: float, wind: WindField | None = None) -> None:
    """Fly a heading [deg true]; LNAV off (BlueSky's HDG).

    In wind, as in BlueSky, the autopilot then holds the track that this
    heading gives at the aircraft's position and speed now.
    """
    F = traffic.F
    track = heading_deg
    if wind is not None and wind.active and F[f.ALT, slot] > APPLY_ABOVE_M:
        vn, ve = wind.get(F[f.LAT, slot], F[f.LON, slot], F[f.ALT, slot])
        hrad = math.radians(heading_deg)
        tas = F[f.TAS, slot]
        track = math.degrees(math.atan2(tas * math.sin(hrad) + ve, tas * math.cos(hrad) + vn)) % 360.0
    F[f.AP_TRK, slot] = track
    traffic.B[f.B_SWLNAV, slot] = False


def apply_wind_at_creation(traffic: Traffic, slot: int, wind: WindField) -> None:
    """Ground speed and track of a new aircraft in the wind; its autopilot holds that track (as BlueSky)."""
    F = traffic.F
    vn, ve = wind.get(F[f.LAT, slot], F[f.LON, slot], F[f.ALT, slot])
    if F[f.ALT, slot] > APPLY_ABOVE_M:
        F[f.GSNORTH, slot] += vn
        F[f.GSEAST, slot] += ve
        # Not wrapped to 0..360 (BlueSky's creation does not); the first step wraps it.
        F[f.TRK, slot] = math.degrees(math.atan2(F[f.GSEAST, slot], F[f.GSNORTH, slot]))
    F[f.GS, slot] = math.sqrt(F[f.GSNORTH, slot] ** 2 + F[f.GSEAST, slot] ** 2)
    F[f.AP_TRK, slot] = F[f.TRK, slot]


def command_resolution(traffic: Traffic, slots: Slots, trk_deg: float | np.ndarray, gs_mps: float | np.ndarray,
                       vs_mps: float | np.ndarray, alt_m: float | np.ndarray) -> None:
    """The conflict resolution's track, ground speed, vertical speed and altitude (BlueSky's cr.trk/tas/vs/alt).

    Flown only by aircraft that follow the resolution (:func:`follow_resolution`);
    the wind is taken off the ground speed and the performance limits apply as
    for the autopilot's commands.
    """
    F = traffic.F
    F[f.ASAS_TRK, slots] = trk_deg
    F[f.ASAS_GS, slots] = gs_mps
    F[f.ASAS_VS, slots] = vs_mps
    F[f.ASAS_ALT, slots] = alt_m


def follow_resolution(traffic: Traffic, slots: Slots, on: bool | np.ndarray) -> None:
    """Fly the resolution's commands instead of the autopilot's (on) or the autopilot's again (BlueSky's cr.active)."""
    traffic.B[f.B_ASAS, slots] = on
    traffic.resolution_used = bool(traffic.B[f.B_ASAS, : traffic.n].any())


def set_cruise_speed(traffic: Traffic, slot: int, cas_mps: float) -> None:
    """CAS [m/s] selected when a fly-turn ends (BlueSky's CRUISESPD), within the type's speed range."""
    F = traffic.F
    traffic.F[f.CRUISESPD, slot] = min(F[f.VMAX, slot], max(cas_mps, F[f.VMIN, slot]))


def set_bank(traffic: Traffic, slot: int, bank_rad: float) -> None:
    """Bank angle used in turns [rad]."""
    traffic.F[f.BANKDEF, slot] = bank_rad


def move(traffic: Traffic, slot: int, lat: float, lon: float, alt_m: float | None = None,
         hdg_deg: float | None = None, speed: float | None = None, speed_is_mach: bool = False,
         vs_mps: float | None = None) -> None:
    """Put an aircraft somewhere else (BlueSky's MOVE); ``speed`` is CAS m/s or Mach."""
    F, B = traffic.F, traffic.B
    F[f.LAT, slot] = lat
    F[f.LON, slot] = lon
    F[f.COSLAT, slot] = math.cos(math.radians(lat))
    if alt_m is not None:
        F[f.ALT, slot] = alt_m
        F[f.SELALT, slot] = alt_m
    if hdg_deg is not None:
        F[f.HDG, slot] = hdg_deg
        F[f.AP_TRK, slot] = hdg_deg
    if speed is not None:
        h = F[f.ALT, slot]
        tas = aero.mach2tas(speed, h) if speed_is_mach else aero.cas2tas(speed, h)
        F[f.TAS, slot] = float(tas)
        F[f.SELSPD, slot] = speed
        B[f.B_SELSPD_MACH, slot] = speed_is_mach
    if vs_mps is not None:
        F[f.VS, slot] = vs_mps
        B[f.B_SWVNAV, slot] = False


def offset_altitude(traffic: Traffic, slots: Slots, dz_m: float | np.ndarray) -> None:
    """Shift aircraft and their selected altitude by ``dz_m`` (e.g. altitude noise at creation)."""
    traffic.F[f.ALT, slots] += dz_m
    traffic.F[f.SELALT, slots] += dz_m


def set_navigation(traffic: Traffic, slot: int, lnav: bool | None = None, vnav: bool | None = None,
                   vnav_speed: bool | None = None) -> None:
    """Switch lateral / vertical navigation and VNAV speed control (None: leave as is)."""
    for row, on in ((f.B_SWLNAV, lnav), (f.B_SWVNAV, vnav), (f.B_SWVNAVSPD, vnav_speed)):
        if on is not None:
            traffic.B[row, slot] = on


def set_climb_profile(traffic: Traffic, slot: int, early_climb: bool | None = None,
                      late_descent: bool | None = None) -> None:
    """BlueSky's SWTOC (climb as early as possible) and SWTOD (descend as late as possible)."""
    if early_climb is not None:
        traffic.B[f.B_SWTOC, slot] = early_climb
    if late_descent is not None:
        traffic.B[f.B_SWTOD, slot] = late_descent


def direct_to(traffic: Traffic, slot: int, index: int) -> None:
    """Fly straight to waypoint ``index`` of the aircraft's route (LNAV on)."""
    activate_waypoint(traffic, slot, index)


def resume_route(traffic: Traffic, slot: int) -> None:
    """LNAV on towards the route's waypoint nearest to the aircraft (BlueSky's LNAV ON)."""
    activate_waypoint(traffic, slot, nearest_active_index(traffic, slot))


def engage_vnav(traffic: Traffic, slot: int) -> None:
    """VNAV and VNAV speed on, planned to the active waypoint's altitude constraint."""
    set_navigation(traffic, slot, vnav=True, vnav_speed=True)
    route = traffic.routes[slot]
    route.plan()
    wp = route.waypoints[route.iactwp]
    compute_vnav(traffic, slot, wp.toalt, wp.xtoalt)
    traffic.F[f.WP_NEXTALTCO, slot] = wp.toalt


def refresh_performance(traffic: Traffic) -> bool:
    """The performance refresh: limits that follow the aircraft's state, as BlueSky's timer sets them.

    Every aircraft gets its type's acceleration limit, and fixed-wing aircraft
    of BlueSky's OpenAP types then their phase, speed range and thrust-limited
    acceleration (:func:`aamsim.traffic.openap.refresh`). Returns whether any
    aircraft's limits depend on its state, so that the next refresh changes
    them again.
    """
    n = traffic.n
    F = traffic.F
    F[f.AXMAX, :n] = F[f.AXMAX_TYPE, :n]
    # Checked here first, so that runs without fixed-wing aircraft never load the compiled model.
    if not np.isfinite(F[f.FW_MASS, :n]).any():
        return False
    return bool(openap.refresh(F, n))


# State another simulator owns (the BlueSky backend overwrites aamsim's with BlueSky's).
SYNC_FIELDS = ("lat", "lon", "alt", "hdg", "trk", "tas", "cas", "gs", "vs", "gsnorth", "gseast", "ax")


def set_kinematic_state(traffic: Traffic, slots: np.ndarray, values: dict[str, np.ndarray]) -> None:
    """Overwrite position, speeds and directions of ``slots`` (one array per name of ``SYNC_FIELDS``).

    The caches that depend on them are invalidated, so the next step
    recomputes them from the new state.
    """
    F = traffic.F
    for name in SYNC_FIELDS:
        F[f.FLOAT_FIELDS.index(name), slots] = values[name]
    F[f.COSLAT, slots] = np.cos(np.radians(values["lat"]))
    F[f.MACH, slots] = aero.tas2mach(values["tas"], values["alt"])
    for row in (f.C_ALT, f.C_HDG, f.C_TAS_IN, f.C_SPD_IN, f.C_LAT, f.C_LA0, f.C_Q0, f.C_Q0COS, f.C_Q0SIN):
        F[row, slots] = math.nan


# Fields a direct write may set (BlueSky's ``traf.alt[i] = x``, see aamsim.compat.bluesky): public names
# (aamsim.traffic.view) -> rows. Derived and cached rows (coslat, the c_* caches) follow from them.
OVERWRITABLE_FLOATS = {name: f.FLOAT_FIELDS.index(name) for name in (
    "lat", "lon", "alt", "hdg", "trk", "tas", "cas", "mach", "gs", "gsnorth", "gseast", "vs", "ax", "distflown",
    "selspd", "selalt", "selvs", "ap_trk", "ap_tas", "ap_alt", "ap_vs", "bankdef")}
OVERWRITABLE_FLAGS = {"lnav": f.B_SWLNAV, "vnav": f.B_SWVNAV, "vnav_speed": f.B_SWVNAVSPD,
                      "selspd_mach": f.B_SELSPD_MACH}


def overwrite_state(traffic: Traffic, slots: np.ndarray, name: str, values: np.ndarray) -> None:
    """Set one field of ``slots`` as a plain write would, with no other effect (no mode switches).

    Only the fields of :data:`OVERWRITABLE_FLOATS` / :data:`OVERWRITABLE_FLAGS`. The
    caches that depend on the state are dropped, so the next step computes from the
    written values (a written latitude also sets cos(lat), as BlueSky's next step would).
    """
    if name in OVERWRITABLE_FLAGS:
        traffic.B[OVERWRITABLE_FLAGS[name], slots] = values
        return
    row = OVERWRITABLE_FLOATS.get(name)
    if row is None:
        raise KeyError(f"{name} cannot be written directly (writable: "
                       f"{', '.join([*OVERWRITABLE_FLOATS, *OVERWRITABLE_FLAGS])})")
    F = traffic.F
    F[row, slots] = values
    if row == f.LAT:
        F[f.COSLAT, slots] = np.cos(np.radians(F[f.LAT, slots]))
    for cache in (f.C_ALT, f.C_HDG, f.C_TAS_IN, f.C_SPD_IN, f.C_LAT, f.C_LA0, f.C_Q0, f.C_Q0COS, f.C_Q0SIN):
        F[cache, slots] = math.nan


def set_replay_state(traffic: Traffic, slots: np.ndarray, lat: np.ndarray, lon: np.ndarray, alt_m: np.ndarray,
                     gsnorth_mps: np.ndarray, gseast_mps: np.ndarray, vs_mps: np.ndarray) -> None:
    """Put replayed (non-cooperative) aircraft at a recorded state; velocities east/north/up [m/s].

    Heading and track follow the ground velocity and TAS equals ground speed (aamsim has no
    wind); the kernel then flies them straight at that velocity until the next update.
    """
    F = traffic.F
    gs = np.hypot(gsnorth_mps, gseast_mps)
    trk = np.mod(np.degrees(np.arctan2(gseast_mps, gsnorth_mps)), 360.0)
    trk = np.where(trk >= 360.0, 0.0, trk)
    for row, values in ((f.LAT, lat), (f.LON, lon), (f.ALT, alt_m), (f.GSNORTH, gsnorth_mps),
                        (f.GSEAST, gseast_mps), (f.VS, vs_mps), (f.GS, gs), (f.TAS, gs), (f.HDG, trk),
                        (f.TRK, trk), (f.SELALT, alt_m), (f.SELSPD, gs)):
        F[row, slots] = values
    F[f.CAS, slots] = aero.tas2cas(gs, alt_m)
    F[f.MACH, slots] = aero.tas2mach(gs, alt_m)
    F[f.AX, slots] = 0.0
    F[f.COSLAT, slots] = np.cos(np.radians(lat))
    for row in (f.C_ALT, f.C_HDG, f.C_TAS_IN, f.C_SPD_IN, f.C_LAT, f.C_LA0, f.C_Q0, f.C_Q0COS, f.C_Q0SIN):
        F[row, slots] = math.nan


def displace(traffic: Traffic, slots: Slots, dnorth_m: np.ndarray, deast_m: np.ndarray, dalt_m: np.ndarray) -> None:
    """Move aircraft by small offsets [m] without touching their speeds (turbulence).

    As BlueSky's turbulence: latitude by ``dnorth / R``, longitude by
    ``deast / (R cos lat)`` with R = 6371 km. The guidance caches that depend
    on the position are invalidated.
    """
    F = traffic.F
    F[f.ALT, slots] += dalt_m
    F[f.LAT, slots] += np.degrees(dnorth_m / R_EARTH)
    F[f.LON, slots] += np.degrees(deast_m / R_EARTH / F[f.COSLAT, slots])
    F[f.COSLAT, slots] = np.cos(np.radians(F[f.LAT, slots]))
    for row in (f.C_ALT, f.C_LAT, f.C_LA0, f.C_Q0, f.C_Q0COS, f.C_Q0SIN):
        F[row, slots] = math.nan
