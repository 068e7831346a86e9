"""Schedule CSV headers: field names, aliases and units.

Headers are matched by name: case-insensitive, spaces, dashes and dots
count as underscores, and each field has documented aliases (``pax`` for
``passengers``...). A unit may follow the name in brackets or as a suffix
(``cruise_speed [m/s]``, ``cruise_alt_ft``); without one the documented
default applies. See ``docs/uamtoolkit-format.md``.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field

from uamtoolkit_import.times import TIME_UNITS_S


class ScheduleFormatError(ValueError):
    """The schedule cannot be read at all (unreadable file, bad or missing headers)."""


@dataclass(frozen=True)
class FieldSpec:
    """A schedule field: its aliases, whether it is required, and its units (factor to the default)."""

    name: str
    aliases: tuple[str, ...]
    required: bool
    units: dict[str, float] = field(default_factory=dict)
    default_unit: str = ""


_SPEED_UNITS = {
    "kts": 1.0,
    "kt": 1.0,
    "kn": 1.0,
    "knot": 1.0,
    "knots": 1.0,
    "mps": 1.0 / 0.514444,
    "m/s": 1.0 / 0.514444,
    "m_s": 1.0 / 0.514444,
    "kmh": 1.0 / 1.852,
    "km/h": 1.0 / 1.852,
    "kph": 1.0 / 1.852,
    "km_h": 1.0 / 1.852,
}
_ALT_UNITS = {"ft": 1.0, "feet": 1.0, "m": 1.0 / 0.3048, "meters": 1.0 / 0.3048, "metres": 1.0 / 0.3048}
_MASS_UNITS = {"kg": 1.0, "lb": 0.45359237, "lbs": 0.45359237}

FIELDS: tuple[FieldSpec, ...] = (
    FieldSpec("flight_id", ("flight_id", "flight", "flightid", "flight_number", "flight_no", "id", "callsign"), True),
    FieldSpec(
        "tail_id",
        ("tail_id", "tail", "tail_number", "aircraft_id", "vehicle_id", "aircraft", "vehicle", "registration"),
        False,
    ),
    FieldSpec("aircraft_type", ("aircraft_type", "type", "ac_type", "actype", "vehicle_type", "model"), False),
    FieldSpec(
        "origin",
        ("origin", "origin_vertiport", "orig", "from", "departure_vertiport", "dep_vertiport", "origin_id"),
        True,
    ),
    FieldSpec(
        "destination",
        ("destination", "destination_vertiport", "dest", "to", "arrival_vertiport", "arr_vertiport", "destination_id"),
        True,
    ),
    FieldSpec(
        "departure_time",
        (
            "departure_time",
            "scheduled_departure",
            "scheduled_departure_time",
            "departure",
            "dep_time",
            "sched_dep",
            "std",
            "etd",
        ),
        True,
        TIME_UNITS_S,
        "s",
    ),
    FieldSpec(
        "arrival_time",
        (
            "arrival_time",
            "scheduled_arrival",
            "scheduled_arrival_time",
            "arrival",
            "arr_time",
            "sched_arr",
            "sta",
            "eta",
        ),
        False,
        TIME_UNITS_S,
        "s",
    ),
    FieldSpec("route", ("route", "route_nodes", "assigned_route", "path", "nodes", "waypoints"), False),
    FieldSpec("cruise_speed", ("cruise_speed", "cruising_speed", "cruise_spd", "speed"), True, _SPEED_UNITS, "kts"),
    FieldSpec(
        "cruise_alt",
        ("cruise_alt", "cruise_altitude", "cruising_altitude", "lane_altitude", "lane_alt", "altitude", "alt", "lane"),
        True,
        _ALT_UNITS,
        "ft",
    ),
    FieldSpec("passengers", ("passengers", "pax", "n_passengers", "passenger_count"), False),
    FieldSpec("cargo", ("cargo", "cargo_mass", "cargo_weight", "payload"), False, _MASS_UNITS, "kg"),
)

CANONICAL_HEADER = (
    "flight_id",
    "tail_id",
    "aircraft_type",
    "origin",
    "destination",
    "departure_time",
    "arrival_time",
    "route",
    "cruise_speed_kts",
    "cruise_alt_ft",
    "passengers",
    "cargo_kg",
)

_BRACKET_UNIT = re.compile(r"^(.*?)\s*[\[(]\s*([^\])]*?)\s*[\])]\s*$")


def normalise_header(header: str) -> tuple[str, str]:
    """``"Cruise Speed (kts)"`` -> ``("cruise_speed", "kts")``; the unit is '' when absent."""
    h = header.strip().lower().lstrip("\ufeff")
    unit = ""
    m = _BRACKET_UNIT.match(h)
    if m:
        h, unit = m.group(1), m.group(2).strip()
    base = re.sub(r"[\s\-.]+", "_", h).strip("_")
    return base, unit


def resolve_headers(headers: Sequence[str], source: str) -> dict[str, tuple[int, float]]:
    """Map each schedule field to (column index, unit factor to the default unit).

    Raises:
        ScheduleFormatError: an unknown unit, a field given twice, or a required field missing.
    """
    by_alias = {alias: spec for spec in FIELDS for alias in spec.aliases}
    found: dict[str, tuple[int, float]] = {}
    for col, raw in enumerate(headers):
        base, unit = normalise_header(raw)
        spec = by_alias.get(base)
        if spec is None and not unit:
            for candidate in FIELDS:
                for u in candidate.units:
                    stem = base[: -len(u) - 1] if base.endswith("_" + u.replace("/", "_")) else ""
                    if stem and stem in candidate.aliases:
                        spec, unit = candidate, u
                        break
                if spec is not None:
                    break
        if spec is None:
            continue  # extra columns are allowed and ignored
        factor = 1.0
        if unit:
            if unit not in spec.units:
                known = ", ".join(sorted(spec.units)) or "none"
                raise ScheduleFormatError(
                    f"{source}:1: header '{raw}': unknown unit '{unit}' for {spec.name} (known: {known})"
                )
            factor = spec.units[unit]
        if spec.name in found:
            first = headers[found[spec.name][0]]
            raise ScheduleFormatError(f"{source}:1: headers '{first}' and '{raw}' both give {spec.name}")
        found[spec.name] = (col, factor)
    missing = [s.name for s in FIELDS if s.required and s.name not in found]
    if missing:
        raise ScheduleFormatError(
            f"{source}:1: missing column(s) {', '.join(missing)} "
            f"(headers found: {', '.join(h.strip() for h in headers) or 'none'})"
        )
    return found
