"""``flights.csv``: one row per flight, closed at deletion."""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable
from pathlib import Path

from aamsim.traffic.traffic import FlightRecord

FLIGHT_COLUMNS = ["id", "type", "created_s", "deleted_s", "arrived", "origin", "destination", "distance_m", "airborne_s"]


def _num(value: float, digits: int) -> str:
    return "" if value is None or math.isnan(value) else f"{value:.{digits}f}"


def write_flights(path: Path, flights: Iterable[FlightRecord]) -> int:
    """Write the flight table; ``deleted_s`` is empty for flights still airborne at the end."""
    count = 0
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(FLIGHT_COLUMNS)
        for rec in flights:
            writer.writerow(
                [
                    rec.acid,
                    rec.actype,
                    _num(rec.created_s, 2),
                    _num(rec.deleted_s, 2),
                    "true" if rec.arrived else "false",
                    rec.origin,
                    rec.destination,
                    _num(rec.distance_m, 1),
                    _num(rec.airborne_s, 2),
                ]
            )
            count += 1
    return count
