"""Which column is which field, in which unit: the table of names the formats use.

OpenSky's own names (``state_vectors_data4`` and the REST API) are SI: m, m/s. The ``traffic``
library renames them and converts to aviation units (``altitude`` ft, ``groundspeed`` kt,
``vertical_rate`` ft/min), and so does ``pyopensky`` by default. Two names are shared by both
families with different units (``geoaltitude``, ``vertical_rate``): they take the unit of the
file's family, decided by the names that belong to one family only. A file whose names come
from both families is refused (mixed units) unless ``units=`` says what each column is.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from typing import Literal

from aamsim.realtraffic.reports import RecordingError
from aamsim.units import FT, NM

#: Factor to SI for every unit a column can have.
TO_SI = {"m": 1.0, "ft": FT, "m/s": 1.0, "kt": NM / 3600.0, "ft/min": FT / 60.0, "deg": 1.0, "s": 1.0}
#: Units each unit-bearing field accepts in ``units=``.
FIELD_UNITS = {"alt_baro": ("m", "ft"), "alt_geo": ("m", "ft"), "gs": ("m/s", "kt"), "vs": ("m/s", "ft/min")}
#: The unit of a shared name, by family.
FAMILY_UNITS = {"opensky": {"alt_geo": "m", "vs": "m/s"}, "traffic": {"alt_geo": "ft", "vs": "ft/min"}}
SHARED = "by family"


@dataclass(frozen=True)
class ColumnSpec:
    field: str
    unit: str | None  # None: no unit (text, bool); "epoch": timestamps, see readers; SHARED: by family
    family: str | None  # the naming family the name belongs to only, if any


def _spec(field: str, unit: str | None, family: str | None = None) -> ColumnSpec:
    return ColumnSpec(field, unit, family)


#: Every column name a reader understands (lower case).
KNOWN: dict[str, ColumnSpec] = {
    "time": _spec("t", "s"),  # state_vectors_data4: integer s since the epoch
    "t_s": _spec("t", "s"),
    "timestamp": _spec("t", "epoch"),  # traffic: datetime, ISO text or epoch s/ms/us/ns
    "icao24": _spec("icao24", None),
    "callsign": _spec("callsign", None),
    "lat": _spec("lat", "deg"),
    "latitude": _spec("lat", "deg"),
    "lon": _spec("lon", "deg"),
    "longitude": _spec("lon", "deg"),
    "baroaltitude": _spec("alt_baro", "m", "opensky"),
    "baro_altitude": _spec("alt_baro", "m", "opensky"),
    "altitude": _spec("alt_baro", "ft", "traffic"),
    "alt_m": _spec("alt_baro", "m"),
    "alt_ft": _spec("alt_baro", "ft"),
    "geoaltitude": _spec("alt_geo", SHARED),
    "geo_altitude": _spec("alt_geo", "m", "opensky"),
    "velocity": _spec("gs", "m/s", "opensky"),
    "groundspeed": _spec("gs", "kt", "traffic"),
    "gs_mps": _spec("gs", "m/s"),
    "gs_kt": _spec("gs", "kt"),
    "heading": _spec("trk", "deg"),  # OpenSky calls the true track over ground "heading"
    "track": _spec("trk", "deg"),
    "true_track": _spec("trk", "deg"),
    "trk_deg": _spec("trk", "deg"),
    "vertrate": _spec("vs", "m/s", "opensky"),
    "vertical_rate": _spec("vs", SHARED),  # ft/min in traffic files, m/s in REST-named files
    "vs_mps": _spec("vs", "m/s"),
    "vs_fpm": _spec("vs", "ft/min"),
    "onground": _spec("on_ground", None),
    "on_ground": _spec("on_ground", None),
}

#: Columns the formats carry that the reports do not need: read past, never an error.
IGNORED = frozenset(
    {
        "", "index", "unnamed: 0",  # a pandas index written by to_csv
        "alert", "spi", "squawk", "hour", "serials", "sensors", "origin_country", "position_source",
        "category", "lastposupdate", "lastcontact", "last_position", "last_contact", "time_position",
        "flight_id", "firstseen", "lastseen", "origin", "destination", "registration", "typecode",
    }
)

REQUIRED = {"t": "time ('time' or 'timestamp')", "icao24": "'icao24'"}
AltitudeChoice = Literal["auto", "baro", "geo"]


@dataclass(frozen=True)
class ColumnPlan:
    """The columns a file's reports come from: ``fields`` maps a field to (column as the file
    spells it, unit); fields: t, icao24, callsign, lat, lon, alt, gs, trk, vs, on_ground."""

    path: str
    fields: Mapping[str, tuple[str, str | None]]
    family: str | None

    @property
    def columns(self) -> list[str]:
        return [column for column, _ in self.fields.values()]

    def describe(self) -> str:
        return ", ".join(f"{f}<-{c}" + (f" [{u}]" if u else "") for f, (c, u) in self.fields.items())


def plan_columns(
    path: str,
    names: Iterable[str],
    *,
    units: Mapping[str, str] | None = None,
    altitude: AltitudeChoice = "auto",
    ignore_columns: Collection[str] = (),
    allow_unknown_columns: bool = False,
) -> ColumnPlan:
    """Map a file's column names to report fields and units, or raise :class:`RecordingError`.

    Args:
        path: the file, for messages.
        names: its column names (case and surrounding blanks do not matter).
        units: unit of a column whose name does not tell it, e.g. ``{"altitude": "m"}``
            (pyopensky with ``nautical_units=False``). Units: m, ft, m/s, kt, ft/min.
        altitude: ``"baro"``, ``"geo"``, or ``"auto"`` (barometric when the file has it).
        ignore_columns: more column names to read past.
        allow_unknown_columns: read past every column not in the table instead of refusing it.
    """
    overrides = {k.strip().lower(): v for k, v in (units or {}).items()}
    ignored = IGNORED | {c.strip().lower() for c in ignore_columns}
    by_field: dict[str, tuple[str, ColumnSpec]] = {}
    seen: set[str] = set()
    for raw in names:
        original = str(raw)
        name = original.strip().lower()
        if name in seen:
            raise RecordingError(path, "appears twice", column=name)
        seen.add(name)
        spec = KNOWN.get(name)
        if spec is None:
            if name in ignored or allow_unknown_columns:
                continue
            raise RecordingError(
                path, "unknown column (pass ignore_columns= or allow_unknown_columns=True to read past it)", name
            )
        if spec.field in by_field:
            other = by_field[spec.field][0]
            raise RecordingError(path, f"gives {spec.field} like column {other!r}: which one is meant?", name)
        by_field[spec.field] = (original, spec)
    used = {name.strip().lower() for name, _ in by_field.values()}
    for name in overrides:
        if name not in used:
            raise RecordingError(path, "units= names a column the file does not use", name)
    family = _family(path, by_field, overrides)
    for field, what in REQUIRED.items():
        if field not in by_field:
            raise RecordingError(path, f"no {what} column")
    if "lat" not in by_field or "lon" not in by_field:
        missing = "lat" if "lat" not in by_field else "lon"
        raise RecordingError(path, "no position: a latitude and a longitude column are needed", missing)
    alt_field = _altitude_field(path, by_field, altitude)
    fields: dict[str, tuple[str, str | None]] = {}
    for field, (name, spec) in by_field.items():
        if field in ("alt_baro", "alt_geo"):
            if field != alt_field:
                continue
            field = "alt"
        fields[field] = (name, _unit(path, name, spec, family, overrides))
    return ColumnPlan(path=path, fields=fields, family=family)


def _family(path: str, by_field: Mapping[str, tuple[str, ColumnSpec]], overrides: Mapping[str, str]) -> str | None:
    """The one naming family the unit-bearing names belong to, or None; mixed families raise."""
    families: dict[str, str] = {}
    for name, spec in by_field.values():
        if spec.family is not None and name.strip().lower() not in overrides:
            families.setdefault(spec.family, name)
    if len(families) > 1:
        (_, col_a), (_, col_b) = sorted(families.items())  # opensky < traffic
        raise RecordingError(
            path,
            f"mixed units: {col_a!r} is an OpenSky (SI) name, {col_b!r} a traffic-library (ft, kt, ft/min) "
            "name; say what each is with units=",
            column=col_b,
        )
    return next(iter(families), None)


def _altitude_field(path: str, by_field: Mapping[str, tuple[str, ColumnSpec]], altitude: AltitudeChoice) -> str:
    if altitude == "auto":
        if "alt_baro" in by_field:
            return "alt_baro"
        if "alt_geo" in by_field:
            return "alt_geo"
        raise RecordingError(path, "no altitude column (baroaltitude, altitude, geoaltitude, ...)")
    field = {"baro": "alt_baro", "geo": "alt_geo"}.get(altitude)
    if field is None:
        raise ValueError(f"altitude must be 'auto', 'baro' or 'geo', not {altitude!r}")
    if field not in by_field:
        raise RecordingError(path, f"altitude={altitude!r} but the file has no {altitude} altitude column")
    return field


def _unit(
    path: str, name: str, spec: ColumnSpec, family: str | None, overrides: Mapping[str, str]
) -> str | None:
    key = name.strip().lower()
    if key in overrides:
        unit = overrides[key]
        allowed = FIELD_UNITS.get(spec.field, ())
        if unit not in allowed:
            raise RecordingError(path, f"unit {unit!r} not one of {', '.join(allowed) or 'none (no unit)'}", name)
        return unit
    if spec.unit != SHARED:
        return spec.unit
    if family is None:
        raise RecordingError(
            path,
            "its unit depends on the source (m or ft, m/s or ft/min) and no other column tells it; "
            "say it with units=",
            name,
        )
    return FAMILY_UNITS[family][spec.field]
