"""Read-only named views of the traffic state (the public way to read aircraft).

``TrafficView(traffic).lat`` is a read-only numpy view of the live aircraft's
latitudes: no copy, so hot paths (observations, baselines) read the state at
no cost, and writing it raises ``ValueError`` (changes go through
:mod:`aamsim.traffic.intents`). Views follow the traffic: taken again after
aircraft are created or deleted they cover the new set (a view held across
a creation or deletion is stale, as any numpy slice would be).

Units are SI: m, m/s, m/s^2, s, degrees for lat/lon/heading/track.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from aamsim.traffic import fields as f
from aamsim.traffic.traffic import Traffic

# Public float fields: name -> meaning (the documented part of the state; docs/api.md lists them).
PUBLIC_FLOATS: dict[str, str] = {
    "lat": "latitude [deg]",
    "lon": "longitude [deg]",
    "alt": "altitude [m]",
    "hdg": "true heading [deg]",
    "trk": "ground track [deg]",
    "tas": "true airspeed [m/s]",
    "cas": "calibrated airspeed [m/s]",
    "mach": "Mach number [-]",
    "gs": "ground speed [m/s]",
    "gsnorth": "ground speed, north component [m/s]",
    "gseast": "ground speed, east component [m/s]",
    "vs": "vertical speed [m/s]",
    "ax": "longitudinal acceleration [m/s^2]",
    "distflown": "distance flown [m]",
    "airborne_s": "time airborne [s]",
    "slow_s": "time airborne below the holding-speed threshold [s]",
    "created_s": "sim time of creation [s]",
    "selspd": "selected speed [CAS m/s, or Mach where selspd_mach]",
    "selalt": "selected altitude [m]",
    "selvs": "selected vertical speed [m/s] (0: default)",
    "bankdef": "bank angle used in turns [rad]",
    "vmin": "minimum speed of the envelope [m/s]",
    "vmax": "maximum speed of the envelope [m/s]",
    "vsmin": "lowest vertical speed of the envelope [m/s] (negative; BlueSky's OpenAP fixed-wing data: a small positive rate)",
    "vsmax": "highest vertical speed of the envelope [m/s]",
    "ap_trk": "track commanded by the autopilot [deg]",
    "ap_tas": "TAS commanded by the autopilot [m/s]",
    "ap_alt": "altitude commanded by the autopilot [m]",
    "ap_vs": "vertical speed commanded by the autopilot [m/s]",
    "axmax": "acceleration limit in use [m/s^2]",
    "dist2wp": "distance to the active waypoint [m]",
    "qdr2wp": "bearing to the active waypoint [deg]",
}
PUBLIC_FLAGS: dict[str, str] = {
    "lnav": "lateral navigation along the route on",
    "vnav": "vertical navigation on",
    "vnav_speed": "VNAV speed control on",
    "selspd_mach": "selected speed is a Mach number",
    "early_climb": "SWTOC: climb as early as possible",
    "late_descent": "SWTOD: descend as late as possible",
    "rotor": "rotorcraft (hovers; speeds in TAS)",
    "noncooperative": "real traffic replayed from a recording (an intruder, never an agent; refuses intents)",
    "resolution": "flies a conflict resolution's commands instead of the autopilot's (BlueSky's ASAS active)",
}
_FLAG_ROWS = {"lnav": f.B_SWLNAV, "vnav": f.B_SWVNAV, "vnav_speed": f.B_SWVNAVSPD, "selspd_mach": f.B_SELSPD_MACH,
              "early_climb": f.B_SWTOC, "late_descent": f.B_SWTOD, "rotor": f.B_ROTOR,
              "noncooperative": f.B_NONCOOP, "resolution": f.B_ASAS}


@functools.lru_cache(maxsize=64)
def field_rows(names: tuple[str, ...]) -> np.ndarray:
    """Rows of float fields by name, for compiled consumers of :func:`kinematic_matrix`."""
    # Left writable: compiled callers would otherwise see a new (read-only) array type and recompile.
    return np.array([f.FLOAT_FIELDS.index(x) for x in names], dtype=np.int64)


def _readonly(arr: np.ndarray) -> np.ndarray:
    view = arr.view()
    view.flags.writeable = False
    return view


def _field_view(name: str, row: int, flag: bool, doc: str) -> Any:
    def get(self: TrafficView) -> np.ndarray:
        # Views are cached until the arrays are replaced or aircraft come or go: hot paths
        # read a dozen fields per decision, and making a read-only view costs more than the lookup.
        t = self._traffic
        key = t.layout_version  # bumped by every creation, deletion and growth of the arrays
        if key != self._key:
            self._key = key
            self._cache = {}
        arr = self._cache.get(name)
        if arr is None:
            arr = self._cache[name] = _readonly((t.B if flag else t.F)[row, : t.n])
        return arr

    get.__doc__ = doc
    return property(get)


def _float_view(name: str) -> Any:
    return _field_view(name, f.FLOAT_FIELDS.index(name), False, PUBLIC_FLOATS[name])


def _flag_view(name: str) -> Any:
    return _field_view(name, _FLAG_ROWS[name], True, PUBLIC_FLAGS[name])


class TrafficView:
    """Read-only named arrays over the live aircraft, indexed by slot (see the module docstring)."""

    __slots__ = ("_cache", "_key", "_traffic")

    def __init__(self, traffic: Traffic):
        self._traffic = traffic
        self._key: int | None = None
        self._cache: dict[str, np.ndarray] = {}

    def __len__(self) -> int:
        return self._traffic.n

    @property
    def n(self) -> int:
        """Number of live aircraft."""
        return self._traffic.n

    @property
    def ids(self) -> tuple[str, ...]:
        """Callsign per slot."""
        return tuple(self._traffic.ids)

    def callsign(self, slot: int) -> str:
        """Callsign of one slot (without copying :attr:`ids`)."""
        return self._traffic.ids[slot]

    def actype(self, slot: int) -> str:
        """Aircraft type of one slot."""
        return self._traffic.types[slot]

    @property
    def types(self) -> tuple[str, ...]:
        """Aircraft type per slot."""
        return tuple(self._traffic.types)

    @property
    def layout_version(self) -> int:
        """Changes whenever aircraft are created or deleted (slots move then)."""
        return self._traffic.layout_version

    def slot(self, acid: str) -> int:
        """Slot of a callsign (raises :class:`aamsim.errors.UnknownAircraft`)."""
        return self._traffic.index(acid)

    def find(self, acid: str) -> int | None:
        """Slot of a callsign, or None."""
        return self._traffic.find(acid)

    def __contains__(self, acid: object) -> bool:
        return acid in self._traffic

    def route(self, slot: int) -> Any:
        """The aircraft's route (waypoints and active index); read it, do not change it."""
        return self._traffic.routes[slot]

    def flight(self, slot: int) -> Any:
        """The aircraft's flight record (origin, destination, schedule)."""
        return self._traffic.flights[slot]

    def rows(self, names: tuple[str, ...]) -> np.ndarray:
        """Several float fields at once, as a new ``(len(names), n)`` array (one gather, for recorders)."""
        t = self._traffic
        return t.F[field_rows(names), : t.n]

    # Named fields (generated from the tables above).
    lat = _float_view("lat")
    lon = _float_view("lon")
    alt = _float_view("alt")
    hdg = _float_view("hdg")
    trk = _float_view("trk")
    tas = _float_view("tas")
    cas = _float_view("cas")
    mach = _float_view("mach")
    gs = _float_view("gs")
    gsnorth = _float_view("gsnorth")
    gseast = _float_view("gseast")
    vs = _float_view("vs")
    ax = _float_view("ax")
    distflown = _float_view("distflown")
    airborne_s = _float_view("airborne_s")
    slow_s = _float_view("slow_s")
    created_s = _float_view("created_s")
    selspd = _float_view("selspd")
    selalt = _float_view("selalt")
    selvs = _float_view("selvs")
    bankdef = _float_view("bankdef")
    vmin = _float_view("vmin")
    vmax = _float_view("vmax")
    vsmin = _float_view("vsmin")
    vsmax = _float_view("vsmax")
    ap_trk = _float_view("ap_trk")
    ap_tas = _float_view("ap_tas")
    ap_alt = _float_view("ap_alt")
    ap_vs = _float_view("ap_vs")
    axmax = _float_view("axmax")
    dist2wp = _float_view("dist2wp")
    qdr2wp = _float_view("qdr2wp")
    lnav = _flag_view("lnav")
    vnav = _flag_view("vnav")
    vnav_speed = _flag_view("vnav_speed")
    selspd_mach = _flag_view("selspd_mach")
    early_climb = _flag_view("early_climb")
    late_descent = _flag_view("late_descent")
    rotor = _flag_view("rotor")
    noncooperative = _flag_view("noncooperative")
    resolution = _flag_view("resolution")


def kinematic_matrix(traffic: Traffic, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """The float matrix and the rows of ``names``, for compiled consumers (conflict detection).

    Compiled kernels read the matrix in place (a copy per check would cost more
    than the check at small N); they must treat it as read-only.
    """
    return traffic.F, field_rows(names)
