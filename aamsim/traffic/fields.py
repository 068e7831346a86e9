"""Row numbers of the per-aircraft state arrays.

Traffic keeps one float64 row per quantity in a 2-D array ``F[field, slot]``
(and booleans in ``B``), so that the Numba step kernel receives the whole
state in two arguments while Python code sees one plain array per field
(``traffic.lat`` is ``F[LAT, :n]``). Units are SI: m, m/s, m/s^2, s; angles
in degrees except where the name says ``_rad``. "No value" is NaN, never a
sentinel.
"""

from __future__ import annotations

FLOAT_FIELDS = (
    # --- state -------------------------------------------------------------
    "lat",  # deg
    "lon",  # deg
    "alt",  # m
    "hdg",  # deg, true heading
    "trk",  # deg, ground track
    "tas",  # m/s
    "cas",  # m/s
    "mach",  # -
    "gs",  # m/s
    "gsnorth",  # m/s
    "gseast",  # m/s
    "vs",  # m/s
    "ax",  # m/s^2, current longitudinal acceleration
    "coslat",  # cos(lat), kept from the position update
    "distflown",  # m, along-track distance flown
    "airborne_s",  # s with alt above the airborne threshold
    "slow_s",  # s airborne below the holding-speed threshold
    "created_s",  # s, sim time of creation
    # --- autopilot selections (MCP) --------------------------------------------
    "selspd",  # CAS m/s or Mach (see B[SELSPD_MACH])
    "selalt",  # m
    "selvs",  # m/s, 0 = use the default vertical speed
    # --- autopilot outputs --------------------------------------------------
    "ap_trk",  # deg
    "ap_tas",  # m/s
    "ap_alt",  # m
    "ap_vs",  # m/s
    "vnavvs",  # m/s
    "dist2vs",  # m, distance before the active waypoint where VNAV starts climbing/descending
    "qdr2wp",  # deg
    "dist2wp",  # m
    "turnphi",  # rad, bank angle used in turns (0 = default bank)
    "bankdef",  # rad
    "vsdef",  # m/s, default vertical speed
    # --- performance envelope ---------------------------------------------------
    "vmin",  # m/s (TAS for rotorcraft, CAS for fixed wing)
    "vmax",  # m/s
    "vsmin",  # m/s (negative)
    "vsmax",  # m/s
    "hmax",  # m
    "axmax",  # m/s^2 in use (refreshed from the type at the performance interval)
    "axmax_type",  # m/s^2 of the aircraft type
    "mmo",  # -, maximum Mach (inf for rotorcraft)
    # --- active waypoint (the leg being flown) -----------------------------------
    "wp_lat",
    "wp_lon",
    "wp_nextaltco",  # m, next altitude constraint (NaN: none)
    "wp_xtoalt",  # m, distance after the active waypoint to that constraint
    "wp_nextspd",  # CAS m/s of the active waypoint (applies from it on; NaN: none)
    "wp_spd",  # CAS m/s in force on this leg (NaN: none)
    "wp_spdcon",  # CAS m/s constraint on this leg (NaN: none)
    "wp_vs",  # m/s, VNAV vertical speed for this leg
    "wp_turndist",  # m, fly-by anticipation distance
    "wp_nextqdr",  # deg, direction of the next leg (NaN: none)
    "wp_curlegdir",  # deg, direction of this leg when it was activated
    "wp_curleglen",  # m
    # --- caches (recomputed only when their inputs change) ------------------------
    "c_alt",  # altitude the atmosphere cache belongs to
    "c_rho",
    "c_p",
    "c_a",  # speed of sound
    "c_hdg",  # heading the sin/cos cache belongs to
    "c_sinhdg",
    "c_coshdg",
    "c_tas_in",  # TAS the CAS cache belongs to
    "c_cas_out",
    "c_spd_in",  # selected speed the TAS cache belongs to
    "c_aptas_out",
    "c_wplat",  # waypoint latitude the sin/cos cache belongs to
    "c_wpsin",
    "c_wpcos",
    "c_bank",  # bank angle the tan cache belongs to
    "c_tanbank",
    "c_lat",  # latitude the sine cache belongs to (set with cos(lat) by the position update)
    "c_sinlat",
    "c_la0",  # rad, anchor latitude of the position update's rotation (see kernel)
    "c_sinla0",
    "c_cosla0",
    "c_q0",  # deg, anchor bearing of the guidance's bearing update (see kernel)
    "c_q0cos",
    "c_q0sin",
)

BOOL_FIELDS = (
    "swlnav",
    "swvnav",
    "swvnavspd",
    "swvnavvs",
    "swhdgsel",
    "swaltsel",
    "swtoc",
    "swtod",
    "selspd_mach",
    "rotor",
    "wp_flyby",
    "wp_lastwp",
    "c_spd_mach",  # Mach flag of the selected speed the TAS cache belongs to
    "has_moved",  # has flown at or above the holding-speed threshold (so slow time counts as holding)
)

N_FLOAT = len(FLOAT_FIELDS)
N_BOOL = len(BOOL_FIELDS)

# Row numbers (checked against the tuples above by the asserts at the end).
LAT, LON, ALT, HDG, TRK, TAS, CAS, MACH, GS, GSNORTH, GSEAST, VS, AX, COSLAT = range(14)
DISTFLOWN, AIRBORNE_S, SLOW_S, CREATED_S = range(14, 18)
SELSPD, SELALT, SELVS = range(18, 21)
AP_TRK, AP_TAS, AP_ALT, AP_VS, VNAVVS, DIST2VS, QDR2WP, DIST2WP, TURNPHI, BANKDEF, VSDEF = range(21, 32)
VMIN, VMAX, VSMIN, VSMAX, HMAX, AXMAX, AXMAX_TYPE, MMO = range(32, 40)
(
    WP_LAT,
    WP_LON,
    WP_NEXTALTCO,
    WP_XTOALT,
    WP_NEXTSPD,
    WP_SPD,
    WP_SPDCON,
    WP_VS,
    WP_TURNDIST,
    WP_NEXTQDR,
    WP_CURLEGDIR,
    WP_CURLEGLEN,
) = range(40, 52)
C_ALT, C_RHO, C_P, C_A, C_HDG, C_SINHDG, C_COSHDG = range(52, 59)
C_TAS_IN, C_CAS_OUT, C_SPD_IN, C_APTAS_OUT, C_WPLAT, C_WPSIN, C_WPCOS, C_BANK, C_TANBANK = range(59, 68)
C_LAT, C_SINLAT, C_LA0, C_SINLA0, C_COSLA0, C_Q0, C_Q0COS, C_Q0SIN = range(68, 76)

(
    B_SWLNAV,
    B_SWVNAV,
    B_SWVNAVSPD,
    B_SWVNAVVS,
    B_SWHDGSEL,
    B_SWALTSEL,
    B_SWTOC,
    B_SWTOD,
    B_SELSPD_MACH,
    B_ROTOR,
    B_WP_FLYBY,
    B_WP_LASTWP,
    B_C_SPD_MACH,
    B_HAS_MOVED,
) = range(14)

assert N_FLOAT == 76 and FLOAT_FIELDS[C_Q0SIN] == "c_q0sin"
assert N_BOOL == 14 and BOOL_FIELDS[B_HAS_MOVED] == "has_moved"
