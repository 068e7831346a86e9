"""Row numbers of the per-aircraft state arrays (private to :mod:`aamsim.traffic`).

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
    "vsmin",  # m/s (negative; positive for BlueSky's OpenAP fixed-wing types, see docs/performance.md)
    "vsmax",  # m/s
    "hmax",  # m
    "axmax",  # m/s^2 in use (refreshed from the type at the performance interval)
    "axmax_type",  # m/s^2 of the aircraft type
    "mmo",  # -, maximum Mach (inf for rotorcraft)
    "takeoff_tas",  # m/s: on the ground (phase GD) below this TAS the aircraft does not climb (NaN: no gate)
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
    # --- fly-turn waypoints (BlueSky's FLYTURN: turn speed, radius, bank) ----------
    "wp_turnspd",  # CAS m/s to fly the turn at the active waypoint (NaN: no turn speed)
    "wp_oldturnspd",  # CAS m/s of the turn at the waypoint just passed, held until on the new leg (NaN: none)
    "wp_nextturnlat",  # deg, next fly-turn waypoint from the active one on (see has_nextturn)
    "wp_nextturnlon",
    "wp_nextturnspd",  # CAS m/s, its turn speed
    "wp_nextturnrad",  # m, its turn radius
    "cruisespd",  # CAS m/s selected when a turn ends (CRUISESPD; NaN: none)
    # --- conflict resolution's commands (BlueSky's cr.trk/tas/vs/alt; flown while the ``asas`` flag is on) ----
    "asas_trk",  # deg, track to fly
    "asas_gs",  # m/s, ground speed to fly (BlueSky's cr.tas, a ground speed: the wind is taken off)
    "asas_vs",  # m/s, vertical speed
    "asas_alt",  # m, altitude
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
    # --- fixed-wing thrust and drag model (BlueSky's OpenAP; NaN for other types) -----
    # Read once per performance refresh, not per step: kept after the rows the kernel
    # reads every step (takeoff_tas is with the envelope) so that those stay packed.
    "phase",  # BlueSky's OpenAP flight phase (aamsim.traffic.openap.PHASE_*), set at each refresh
    "fw_mass",  # kg
    "fw_wing_area",  # m^2
    "fw_max_thrust",  # N, static maximum thrust of all engines
    "fw_cd0_clean",
    "fw_k_clean",
    "fw_cd0_takeoff",
    "fw_k_takeoff",
    "fw_cd0_landing",
    "fw_k_landing",
    "fw_vminto",  # m/s, take-off speed (TAS gate of the ground phase)
    "fw_vmaxic",  # CAS m/s, initial climb (and ground) maximum
    "fw_vminer",  # CAS m/s, en-route range
    "fw_vmaxer",
    "fw_vminap",  # CAS m/s, approach range
    "fw_vmaxap",
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
    "has_nextturn",  # a fly-turn waypoint lies ahead on the route (wp_nextturn* are valid)
    "turntonextwp",  # slowing for, or flying, the turn at the next fly-turn waypoint
    "inturn",  # flying at a turn speed (for CRUISESPD when it ends)
    "noncoop",  # real traffic replayed from a recording: flown straight at its set velocity, no autopilot
    "asas",  # follows the conflict resolution's asas_* commands instead of the autopilot's (BlueSky's cr.active)
)

N_FLOAT = len(FLOAT_FIELDS)
N_BOOL = len(BOOL_FIELDS)


def _row(name: str) -> int:
    """Row of a float field, looked up in the tuple (a misspelt name fails at import)."""
    return FLOAT_FIELDS.index(name)


def _flag(name: str) -> int:
    """Row of a boolean field, looked up in the tuple."""
    return BOOL_FIELDS.index(name)


# Row numbers, generated from the tuples above: the constant for field ``x`` is ``X``
# (``B_X`` for booleans); :func:`_check_rows` proves every field has its constant.
LAT = _row("lat")
LON = _row("lon")
ALT = _row("alt")
HDG = _row("hdg")
TRK = _row("trk")
TAS = _row("tas")
CAS = _row("cas")
MACH = _row("mach")
GS = _row("gs")
GSNORTH = _row("gsnorth")
GSEAST = _row("gseast")
VS = _row("vs")
AX = _row("ax")
COSLAT = _row("coslat")
DISTFLOWN = _row("distflown")
AIRBORNE_S = _row("airborne_s")
SLOW_S = _row("slow_s")
CREATED_S = _row("created_s")
SELSPD = _row("selspd")
SELALT = _row("selalt")
SELVS = _row("selvs")
AP_TRK = _row("ap_trk")
AP_TAS = _row("ap_tas")
AP_ALT = _row("ap_alt")
AP_VS = _row("ap_vs")
VNAVVS = _row("vnavvs")
DIST2VS = _row("dist2vs")
QDR2WP = _row("qdr2wp")
DIST2WP = _row("dist2wp")
TURNPHI = _row("turnphi")
BANKDEF = _row("bankdef")
VSDEF = _row("vsdef")
VMIN = _row("vmin")
VMAX = _row("vmax")
VSMIN = _row("vsmin")
VSMAX = _row("vsmax")
HMAX = _row("hmax")
AXMAX = _row("axmax")
AXMAX_TYPE = _row("axmax_type")
MMO = _row("mmo")
TAKEOFF_TAS = _row("takeoff_tas")
WP_LAT = _row("wp_lat")
WP_LON = _row("wp_lon")
WP_NEXTALTCO = _row("wp_nextaltco")
WP_XTOALT = _row("wp_xtoalt")
WP_NEXTSPD = _row("wp_nextspd")
WP_SPD = _row("wp_spd")
WP_SPDCON = _row("wp_spdcon")
WP_VS = _row("wp_vs")
WP_TURNDIST = _row("wp_turndist")
WP_NEXTQDR = _row("wp_nextqdr")
WP_CURLEGDIR = _row("wp_curlegdir")
WP_CURLEGLEN = _row("wp_curleglen")
WP_TURNSPD = _row("wp_turnspd")
WP_OLDTURNSPD = _row("wp_oldturnspd")
WP_NEXTTURNLAT = _row("wp_nextturnlat")
WP_NEXTTURNLON = _row("wp_nextturnlon")
WP_NEXTTURNSPD = _row("wp_nextturnspd")
WP_NEXTTURNRAD = _row("wp_nextturnrad")
CRUISESPD = _row("cruisespd")
ASAS_TRK = _row("asas_trk")
ASAS_GS = _row("asas_gs")
ASAS_VS = _row("asas_vs")
ASAS_ALT = _row("asas_alt")
C_ALT = _row("c_alt")
C_RHO = _row("c_rho")
C_P = _row("c_p")
C_A = _row("c_a")
C_HDG = _row("c_hdg")
C_SINHDG = _row("c_sinhdg")
C_COSHDG = _row("c_coshdg")
C_TAS_IN = _row("c_tas_in")
C_CAS_OUT = _row("c_cas_out")
C_SPD_IN = _row("c_spd_in")
C_APTAS_OUT = _row("c_aptas_out")
C_WPLAT = _row("c_wplat")
C_WPSIN = _row("c_wpsin")
C_WPCOS = _row("c_wpcos")
C_BANK = _row("c_bank")
C_TANBANK = _row("c_tanbank")
C_LAT = _row("c_lat")
C_SINLAT = _row("c_sinlat")
C_LA0 = _row("c_la0")
C_SINLA0 = _row("c_sinla0")
C_COSLA0 = _row("c_cosla0")
C_Q0 = _row("c_q0")
C_Q0COS = _row("c_q0cos")
C_Q0SIN = _row("c_q0sin")
PHASE = _row("phase")
FW_MASS = _row("fw_mass")
FW_WING_AREA = _row("fw_wing_area")
FW_MAX_THRUST = _row("fw_max_thrust")
FW_CD0_CLEAN = _row("fw_cd0_clean")
FW_K_CLEAN = _row("fw_k_clean")
FW_CD0_TAKEOFF = _row("fw_cd0_takeoff")
FW_K_TAKEOFF = _row("fw_k_takeoff")
FW_CD0_LANDING = _row("fw_cd0_landing")
FW_K_LANDING = _row("fw_k_landing")
FW_VMINTO = _row("fw_vminto")
FW_VMAXIC = _row("fw_vmaxic")
FW_VMINER = _row("fw_vminer")
FW_VMAXER = _row("fw_vmaxer")
FW_VMINAP = _row("fw_vminap")
FW_VMAXAP = _row("fw_vmaxap")

B_SWLNAV = _flag("swlnav")
B_SWVNAV = _flag("swvnav")
B_SWVNAVSPD = _flag("swvnavspd")
B_SWVNAVVS = _flag("swvnavvs")
B_SWHDGSEL = _flag("swhdgsel")
B_SWALTSEL = _flag("swaltsel")
B_SWTOC = _flag("swtoc")
B_SWTOD = _flag("swtod")
B_SELSPD_MACH = _flag("selspd_mach")
B_ROTOR = _flag("rotor")
B_WP_FLYBY = _flag("wp_flyby")
B_WP_LASTWP = _flag("wp_lastwp")
B_C_SPD_MACH = _flag("c_spd_mach")
B_HAS_MOVED = _flag("has_moved")
B_HAS_NEXTTURN = _flag("has_nextturn")
B_TURNTONEXTWP = _flag("turntonextwp")
B_INTURN = _flag("inturn")
B_NONCOOP = _flag("noncoop")
B_ASAS = _flag("asas")


def _check_rows() -> None:
    """Every field has its constant, at its index, and names are unique (runs at import)."""
    for names, prefix in ((FLOAT_FIELDS, ""), (BOOL_FIELDS, "B_")):
        if len(set(names)) != len(names):
            raise ImportError("aamsim.traffic.fields: a field name appears twice")
        for k, name in enumerate(names):
            if globals().get(prefix + name.upper()) != k:
                raise ImportError(f"aamsim.traffic.fields: row constant {prefix}{name.upper()} is not {k}")


_check_rows()
