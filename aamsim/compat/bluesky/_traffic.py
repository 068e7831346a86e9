"""``bs.traf``: BlueSky's traffic object over the session's simulation.

Arrays (``bs.traf.lat``, ``bs.traf.ap.trk``, ...) come from :mod:`._arrays` in
BlueSky's order and units (SI: m, m/s, degrees); methods call the simulator's
API (creation, deletion, intents), never its state arrays. Names BlueSky has and
the shim does not raise :class:`~aamsim.compat.bluesky._errors.NotProvided`.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from aamsim.compat.bluesky import settings
from aamsim.compat.bluesky._arrays import Field, Source, view_field
from aamsim.compat.bluesky._errors import Unprovided, not_provided
from aamsim.compat.bluesky.tools import aero, geo
from aamsim.errors import CommandError
from aamsim.traffic.wind import wind_from
from aamsim.units import Speed

if TYPE_CHECKING:
    from aamsim.compat.bluesky._arrays import ArraySession
    from aamsim.compat.bluesky._session import Session
    from aamsim.traffic.view import TrafficView


def _coslat(view: TrafficView, order: np.ndarray, session: ArraySession) -> np.ndarray:
    return np.cos(np.deg2rad(view.lat[order]))


def _atmosphere(k: int) -> Source:
    def get(view: TrafficView, order: np.ndarray, session: ArraySession) -> np.ndarray:
        return np.asarray(aero.vatmos(view.alt[order])[k], dtype=float)

    return get


def _wind(k: int) -> Source:
    def get(view: TrafficView, order: np.ndarray, session: ArraySession) -> np.ndarray:
        wind = session.simulation._wind
        lat, lon, alt = view.lat[order], view.lon[order], view.alt[order]
        if not wind.active:
            return np.zeros(len(order))
        return np.array([wind.get(lat[i], lon[i], alt[i])[k] for i in range(len(order))])

    return get


def _fields(prefix: str, table: dict[str, tuple[str | Source, bool]]) -> dict[str, Field]:
    out = {}
    for name, (source, writable) in table.items():
        if isinstance(source, str):
            out[name] = Field(prefix + name, view_field(source), source if writable else None)
        else:
            out[name] = Field(prefix + name, source, None)
    return out


# BlueSky name -> (aamsim view field or a function of the state, writable)
TRAFFIC_FIELDS = _fields("", {
    "lat": ("lat", True), "lon": ("lon", True), "alt": ("alt", True), "hdg": ("hdg", True), "trk": ("trk", True),
    "tas": ("tas", True), "gs": ("gs", True), "gsnorth": ("gsnorth", True), "gseast": ("gseast", True),
    "cas": ("cas", True), "M": ("mach", True), "vs": ("vs", True), "ax": ("ax", True),
    "distflown": ("distflown", True), "selspd": ("selspd", True), "selalt": ("selalt", True),
    "selvs": ("selvs", True), "swlnav": ("lnav", True), "swvnav": ("vnav", True),
    "swvnavspd": ("vnav_speed", True), "coslat": (_coslat, False), "p": (_atmosphere(0), False),
    "rho": (_atmosphere(1), False), "Temp": (_atmosphere(2), False), "windnorth": (_wind(0), False),
    "windeast": (_wind(1), False),
})
AUTOPILOT_FIELDS = _fields("ap.", {
    "trk": ("ap_trk", True), "tas": ("ap_tas", True), "alt": ("ap_alt", True), "vs": ("ap_vs", True),
    "bankdef": ("bankdef", True), "dist2wp": ("dist2wp", False), "qdr2wp": ("qdr2wp", False),
})
PERF_FIELDS = _fields("perf.", {
    "vmin": ("vmin", False), "vmax": ("vmax", False), "vsmin": ("vsmin", False), "vsmax": ("vsmax", False),
    "axmax": ("axmax", False),
})


class _Array:
    """A traffic array as an attribute, built by the store on first read (then an instance attribute)."""

    def __init__(self, attr: str, field: Field) -> None:
        self.attr = attr
        self.field = field

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        return obj._session.arrays.get(obj, self.attr, self.field)


def _with_arrays(fields: dict[str, Field]) -> Any:
    def decorate(cls: type) -> type:
        arrays = {name: _Array(name, field) for name, field in fields.items()}
        cls._arrays = arrays  # type: ignore[attr-defined]
        for name, descriptor in arrays.items():
            setattr(cls, name, descriptor)
        return cls

    return decorate


class _WithArrays:
    """Objects whose traffic arrays are attributes: assigning a whole array writes each element."""

    _arrays: ClassVar[dict[str, _Array]] = {}
    _session: Session

    def __setattr__(self, name: str, value: Any) -> None:
        descriptor = type(self)._arrays.get(name)
        if descriptor is None:
            object.__setattr__(self, name, value)
        else:
            self._session.arrays.assign(self, name, descriptor.field, value)


class _Part(_WithArrays):
    """A part of ``bs.traf`` (``ap``, ``wind``, ``perf``): unknown names are not provided."""

    _path = "bluesky.traf"

    def __init__(self, session: Session) -> None:
        self._session = session

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        raise not_provided(f"{self._path}.{name}")


def _scalar_or_each(value: Any, n: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(value, dtype=float), (n,))


def _speed(casmach: float) -> Speed:
    """A speed of the Python API: a Mach number strictly between 0.1 and the threshold, else a CAS [m/s]."""
    return Speed(float(casmach), is_mach=bool(0.1 < casmach < settings.casmach_threshold))


@_with_arrays(AUTOPILOT_FIELDS)
class Autopilot(_Part):
    """``bs.traf.ap``: the autopilot's commands and the selection commands (ALT, VS, HDG, SPD)."""

    _path = "bluesky.traf.ap"

    def _each(self, idx: Any, value: Any) -> list[tuple[int, float]]:
        slots = self._session.slots(idx)
        return list(zip(slots.tolist(), _scalar_or_each(value, len(slots)).tolist(), strict=True))

    def selaltcmd(self, idx: Any, alt: Any, vspd: float | None = None) -> bool:
        """ALT: select altitude ``alt`` [m] (and vertical speed ``vspd`` [m/s]); VNAV off."""
        s = self._session
        s.before_change()
        for slot, value in self._each(idx, alt):
            s.simulation.select_altitude(slot, value, vspd if vspd else None)
        s.changed()
        return True

    def selvspdcmd(self, idx: Any, vspd: Any) -> bool:
        """VS: select vertical speed ``vspd`` [m/s]; VNAV off."""
        s = self._session
        s.before_change()
        for slot, value in self._each(idx, vspd):
            s.simulation.select_vertical_speed(slot, value)
        s.changed()
        return True

    def selhdgcmd(self, idx: Any, hdg: Any) -> bool:
        """HDG: fly heading ``hdg`` [deg] (in wind, the track it gives now); LNAV off."""
        s = self._session
        s.before_change()
        for slot, value in self._each(idx, hdg):
            s.simulation.select_heading(slot, value)
        s.changed()
        return True

    def selspdcmd(self, idx: Any, casmach: Any) -> bool:
        """SPD: select CAS [m/s], or Mach below the CAS/Mach threshold; VNAV speed off."""
        s = self._session
        s.before_change()
        for slot, value in self._each(idx, casmach):
            s.simulation.select_speed(slot, _speed(value))
        s.changed()
        return True

    def _switch(self, command: str, idx: Any, flag: bool | None) -> bool | tuple[bool, str]:
        s = self._session
        names = [s.ids[int(k)] for k in np.atleast_1d(idx)]
        word = "" if flag is None else (" ON" if flag else " OFF")
        s.before_change()
        results = [s.run_line(f"{command} {name}{word}") for name in names]  # every one, even after a failure
        ok = all(results)
        s.changed()
        return True if ok else (False, f"{command} failed (see the echo)")

    def setLNAV(self, idx: Any, flag: bool | None = None) -> bool | tuple[bool, str]:
        """LNAV acid ON/OFF."""
        return self._switch("LNAV", idx, flag)

    def setVNAV(self, idx: Any, flag: bool | None = None) -> bool | tuple[bool, str]:
        """VNAV acid ON/OFF."""
        return self._switch("VNAV", idx, flag)

    @property
    def orig(self) -> list[str]:
        """Origin of each aircraft ('' when none), in BlueSky's order (a copy)."""
        view = self._session.view
        return [view.flight(int(i)).origin for i in self._session.order()]

    @property
    def dest(self) -> list[str]:
        """Destination of each aircraft ('' when none), in BlueSky's order (a copy)."""
        view = self._session.view
        return [view.flight(int(i)).destination for i in self._session.order()]

    @property
    def route(self) -> Any:
        raise not_provided("bluesky.traf.ap.route", "routes are edited with stack commands: ADDWPT, DELWPT, DIRECT")


class Wind(_Part):
    """``bs.traf.wind``: the wind field (BlueSky's points and profiles, inverse distance squared between them)."""

    _path = "bluesky.traf.wind"

    @property
    def winddim(self) -> int:
        """0: no wind, 1: one point (everywhere the same), 2: several points, 3: with altitude profiles."""
        return int(self._session.simulation._wind.dim)

    def getdata(self, userlat: Any, userlon: Any, useralt: Any = 0.0) -> tuple[Any, Any]:
        """North and east wind [m/s]: arrays for arrays, lists for lists, floats otherwise (as BlueSky).

        As BlueSky, the altitude is used when it is an array, a list or a Python float; any other
        value (a numpy scalar among them) reads the wind at 0 m.
        """
        vector = type(userlat) in (list, np.ndarray)
        lat = np.ravel(np.asarray(userlat, dtype=float))
        lon = np.ravel(np.asarray(userlon, dtype=float))
        if type(useralt) in (list, np.ndarray):
            alt = np.broadcast_to(np.asarray(useralt, dtype=float).ravel(), lat.shape)
        elif type(useralt) is float:
            alt = np.full(lat.shape, useralt)
        else:
            alt = np.zeros(lat.shape)
        wind = self._session.simulation._wind
        vn, ve = np.zeros(lat.shape), np.zeros(lat.shape)
        if wind.active:
            for i in range(lat.shape[0]):
                vn[i], ve[i] = wind.get(lat[i], lon[i], alt[i])
        if type(userlat) is np.ndarray:
            return vn, ve
        if vector:
            return list(vn), list(ve)
        return float(vn[0]), float(ve[0])

    def addpoint(self, lat: float, lon: float, winddir: Any, windspd: Any, windalt: Any = None) -> int:
        """Wind from ``winddir`` [deg] at ``windspd`` [m/s] at a point; with ``windalt`` [m] a profile."""
        s = self._session
        s.before_change()
        wind = s.simulation._wind
        if windalt is None:
            idx = wind.add_point(float(lat), float(lon), float(winddir), float(windspd))
        else:
            idx = wind.add_profile(float(lat), float(lon), np.asarray(windalt, float), np.asarray(winddir, float),
                                   np.asarray(windspd, float))
        s.changed()
        return idx

    def addpointvne(self, lat: Any, lon: Any, vnorth: Any, veast: Any, windalt: Any = None) -> None:
        """Wind given as north and east components [m/s] at one or more points (a profile over ``windalt`` [m]).

        BlueSky interpolates four or more points with a profile on a regular grid
        (``RegularGridInterpolator``); aamsim's field uses inverse distance squared
        between the points everywhere (docs/bluesky-api.md).
        """
        lats, lons = np.atleast_1d(np.asarray(lat, float)), np.atleast_1d(np.asarray(lon, float))
        vn, ve = np.asarray(vnorth, float), np.asarray(veast, float)
        for k in range(lats.shape[0]):
            if windalt is None:
                direction, speed = wind_from(float(np.ravel(vn)[k]), float(np.ravel(ve)[k]))
                self.addpoint(lats[k], lons[k], direction, speed)
            else:
                col_n = vn[:, k] if vn.ndim == 2 else vn
                col_e = ve[:, k] if ve.ndim == 2 else ve
                pairs = [wind_from(float(a), float(b)) for a, b in zip(col_n, col_e, strict=True)]
                self.addpoint(lats[k], lons[k], [p[0] for p in pairs], [p[1] for p in pairs], windalt)

    def clear(self) -> None:
        """No wind."""
        s = self._session
        s.before_change()
        s.simulation._wind.clear()
        s.changed()


@_with_arrays(PERF_FIELDS)
class Performance(_Part):
    """``bs.traf.perf``: the envelope of each aircraft (aamsim's performance model, docs/performance.md)."""

    _path = "bluesky.traf.perf"


_UNPROVIDED_PARTS = {
    "cd": "conflict detection: aamsim's conflicts service (docs/metrics.md)",
    "cr": "conflict resolution: the RESO stack command",
    "actwp": "the active waypoint: ap.dist2wp and ap.qdr2wp",
    "adsb": "", "trails": "", "groups": "", "turbulence": "the NOISE stack command", "cond": "", "aporasas": "",
}


@_with_arrays(TRAFFIC_FIELDS)
class Traffic(_WithArrays):
    """``bs.traf``: the aircraft in BlueSky's order, their arrays and BlueSky's traffic methods."""

    def __init__(self, session: Session) -> None:
        self._session = session
        self.ap = Autopilot(session)
        self.wind = Wind(session)
        self.perf = Performance(session)
        self.translvl = 5000.0 * aero.ft  # m, transition level (kept for code that reads it)
        for name, hint in _UNPROVIDED_PARTS.items():
            setattr(self, name, Unprovided(f"bluesky.traf.{name}", hint))

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        raise not_provided(f"bluesky.traf.{name}")

    # ------------------------------------------------------------------ identity
    @property
    def id(self) -> list[str]:
        """Callsigns in BlueSky's order, as given: the same list object throughout (BlueSky's is too)."""
        return self._session.ids

    @property
    def type(self) -> list[str]:
        """Aircraft types, in the same order."""
        return self._session.types

    @property
    def ntraf(self) -> int:
        return len(self._session.ids)

    def id2idx(self, acid: Any) -> Any:
        """Position of a callsign (-1 when unknown; ``'#'``/``'*'``: the last); a list of them for a list."""
        ids = self._session.ids
        if not isinstance(acid, str):
            where = {name: i for i, name in enumerate(ids)}
            return [where.get(a, -1) for a in acid]
        if acid in ("#", "*"):
            return len(ids) - 1
        try:
            return ids.index(acid.upper())
        except ValueError:
            return -1

    # ------------------------------------------------------------------ creation and deletion
    def cre(self, acid: Any, actype: Any = "B744", aclat: Any = 52.0, aclon: Any = 4.0, achdg: Any = None,
            acalt: Any = 0, acspd: Any = 0) -> bool | tuple[bool, str]:
        """Create one aircraft (``acid`` a string) or several (a list): degrees, metres, CAS m/s or Mach.

        A speed strictly between 0.1 and the CAS/Mach threshold (2) is a Mach number, as in
        BlueSky's Python API. Returns True, or ``(False, message)`` (an existing callsign).
        """
        s = self._session
        if isinstance(acid, str):
            if acid.upper() in s.ids:
                return False, acid + " already exists."  # BlueSky's answer, word for word
            acids = [acid]
        else:
            acids = [str(a) for a in acid]
        n = len(acids)
        types = [actype] * n if isinstance(actype, str) else [str(t) for t in actype]
        lat = _scalar_or_each(aclat, n)
        lon = np.array(_scalar_or_each(aclon, n))
        lon[lon > 180.0] -= 360.0
        lon[lon < -180.0] += 360.0
        hdg = _scalar_or_each(0.0 if achdg is None else achdg, n)
        alt = _scalar_or_each(acalt, n)
        _, cas, _ = aero.vcasormach(_scalar_or_each(acspd, n), alt)  # a Mach number is created as its CAS
        # BlueSky's ADS-B model draws one number per new aircraft from numpy's global generator. Code
        # that seeds that generator and draws its scenario from it (bluesky-gym) then draws the same
        # scenarios here only if the shim draws them too.
        np.random.rand(n)
        s.before_change()
        failed = []
        try:
            for k in range(n):
                s.create_as(acids[k], types[k])
                try:
                    s.simulation.create(acids[k], types[k], float(lat[k]), float(lon[k]), float(hdg[k]),
                                        float(alt[k]), Speed(float(cas[k])))
                except CommandError as exc:
                    failed.append(exc.message)
        finally:
            s.forget_naming()
            s.changed()
        if failed:
            s.echo("CRE: " + "; ".join(failed), 2)
            return False, "; ".join(failed)
        return True

    def creconfs(self, acid: str, actype: str, targetidx: int, dpsi: float, dcpa: float, tlosh: float,
                 dH: float | None = None, tlosv: float | None = None,
                 spd: float | None = None) -> bool | tuple[bool, str]:
        """Create an aircraft in conflict with the one at ``targetidx``.

        ``dpsi`` [deg] between the tracks, ``dcpa`` [NM] at the closest point of approach,
        ``tlosh`` [s] to the loss of horizontal separation (BlueSky's protected zone,
        ``settings.asas_pzr``); ``dH`` [m] above the target and ``tlosv`` [s] to the loss of
        vertical separation; ``spd`` CAS [m/s] or Mach (default: the target's ground speed).
        BlueSky's geometry, formula for formula.
        """
        # Read as BlueSky reads them (numpy scalars: the wind below is then read at 0 m, as in BlueSky).
        latref, lonref, altref = self.lat[targetidx], self.lon[targetidx], self.alt[targetidx]
        trkref = math.radians(self.trk[targetidx])
        gsref, vsref = self.gs[targetidx], self.vs[targetidx]
        cpa = dcpa * geo.nm
        pzr = settings.asas_pzr * geo.nm
        pzh = settings.asas_pzh * aero.ft
        trk = trkref + math.radians(dpsi)
        if dH is None:
            acalt, acvs = altref, 0.0
        else:
            acalt = altref + dH
            tlosv = tlosh if tlosv is None else tlosv
            acvs = vsref - np.sign(dH) * (abs(dH) - pzh) / tlosv
        if spd:
            tas = aero.casormach2tas(spd, acalt)
            wn, we = self.wind.getdata(latref, lonref, acalt)
            gsn, gse = tas * math.cos(trk) + wn, tas * math.sin(trk) + we
        else:
            gsn, gse = gsref * math.cos(trk), gsref * math.sin(trk)
        # Relative velocity, then the intruder's start so that it closes to dcpa after tlosh.
        vreln, vrele = gsref * math.cos(trkref) - gsn, gsref * math.sin(trkref) - gse
        vrel = math.sqrt(vreln * vreln + vrele * vrele)
        drelcpa = tlosh * vrel + (0 if cpa > pzr else math.sqrt(pzr * pzr - cpa * cpa))
        dist = math.sqrt(drelcpa * drelcpa + cpa * cpa)
        rd, rx = drelcpa / dist, cpa / dist
        brn = math.degrees(math.atan2(-rx * vreln + rd * vrele, rd * vreln + rx * vrele))
        aclat, aclon = geo.kwikpos(latref, lonref, brn, dist / geo.nm)
        wn, we = self.wind.getdata(aclat, aclon, acalt)
        tasn, tase = gsn - wn, gse - we
        acspd = aero.tas2cas(math.sqrt(tasn * tasn + tase * tase), acalt)
        achdg = math.degrees(math.atan2(tase, tasn))
        created = self.cre(acid, actype, aclat, aclon, achdg, acalt, acspd)
        if created is not True:
            return created
        last = self.ntraf - 1
        self.ap.selaltcmd(last, altref, acvs)
        self.vs[last] = acvs
        return True

    def delete(self, idx: Any) -> bool:
        """Delete the aircraft at position ``idx`` (an int or a collection of them)."""
        s = self._session
        positions = np.sort(np.asarray(idx)) if isinstance(idx, Collection) else [idx]
        names = [s.ids[int(k)] for k in positions]
        s.before_change()
        s.simulation.delete([name.upper() for name in names])
        s.changed()
        return True

    def reset(self) -> None:
        """Delete every aircraft, the wind, turbulence and conditional commands (time goes on)."""
        self._session.reset_traffic()

    def move(self, idx: int, lat: float, lon: float, alt: float | None = None, hdg: float | None = None,
             casmach: float | None = None, vspd: float | None = None) -> None:
        """Put an aircraft elsewhere: degrees, metres, CAS m/s or Mach, m/s (BlueSky's MOVE)."""
        s = self._session
        s.before_change()
        s.simulation.move(int(s.slots(idx)[0]), lat, lon, alt, hdg, None if casmach is None else _speed(casmach),
                          vspd)
        s.changed()

    def setnoise(self, noise: bool | None = None) -> bool | tuple[bool, str]:
        """Turbulence on or off (NOISE); without an argument, whether it is on."""
        s = self._session
        sim = s.simulation
        if noise is None:
            start = len(sim.reporter.messages)
            sim.stack("NOISE")
            texts = [m.text for m in sim.reporter.messages[start:]]
            del sim.reporter.messages[start:]
            return True, "; ".join(texts)
        s.process([f"NOISE {'ON' if noise else 'OFF'}"])
        return True
