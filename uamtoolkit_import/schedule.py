"""Read (and write) UAMToolkit flight schedules: one CSV row per flight.

Headers are matched by name, with aliases and units
(:mod:`uamtoolkit_import.headers`). See ``docs/uamtoolkit-format.md``.

Every row is validated on its own. A bad row yields :class:`RowError`\\ s
that name the file, the row (its line number; the header is line 1) and the
field, and the row is left out; a bad header makes the whole file unusable
(:class:`ScheduleFormatError`). A row is one line: a quoted field cannot span
lines, so an unterminated quote costs only its own row.

Files are read line by line (a 100 MB schedule is never held as one text) in
the encoding :func:`read_lines` detects: a BOM (UTF-8 or UTF-16), UTF-16
without BOM, else UTF-8, and a line that is not UTF-8 is read as cp1252 with a
warning naming the first such line and byte offset.
"""

from __future__ import annotations

import codecs
import csv
import logging
import math
import re
import sys
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from datetime import date
from itertools import pairwise
from pathlib import Path
from typing import IO

from uamtoolkit_import.fields import CALLSIGN_MAX_CHARS, aircraft_type_problem
from uamtoolkit_import.headers import CANONICAL_HEADER, ScheduleFormatError, resolve_headers
from uamtoolkit_import.network import Network
from uamtoolkit_import.times import TimeParseError, format_clock, parse_schedule_time

log = logging.getLogger(__name__)

Report = Callable[[str, str], None]
"""Records an error: (field, message)."""

_ROUTE_SPLIT = re.compile(r"[\s;,|>]+")


@dataclass(frozen=True, slots=True)
class ScheduledFlight:
    """One valid schedule row, in the contract's units.

    Attributes:
        row: line number in the file (the header is line 1).
        flight_id: as written; ``callsign`` is its scenario form (upper-case alphanumeric).
        route: the route's intermediate points (origin and destination removed).
        departure_s, arrival_s: seconds since midnight (``arrival_s`` NaN when not given).
        cruise_speed_kts: cruise CAS [kt]; cruise_alt_ft: lane altitude [ft].
        passengers: count, or None when not given; cargo_kg: [kg], or None when not given.
    """

    row: int  # (slots: a million flights of a 100 MB schedule fit in a few hundred MB)
    flight_id: str
    callsign: str
    tail_id: str
    aircraft_type: str
    origin: str
    destination: str
    departure_s: float
    arrival_s: float
    route: tuple[str, ...]
    cruise_speed_kts: float
    cruise_alt_ft: float
    passengers: int | None = None
    cargo_kg: float | None = None


@dataclass(frozen=True)
class RowError:
    """A problem with one field of one row."""

    path: str
    row: int
    field: str
    message: str

    def __str__(self) -> str:
        return f"{self.path}:{self.row}: field '{self.field}': {self.message}"


@dataclass
class Schedule:
    """The valid flights of a schedule file and the errors of the rows left out."""

    path: str
    flights: list[ScheduledFlight]
    errors: list[RowError]
    rows: int
    warnings: list[str] = field(default_factory=list)  # e.g. the encoding fallback
    encoding: str = "utf-8"

    @property
    def skipped_rows(self) -> int:
        return len({e.row for e in self.errors})


def callsign_for(flight_id: str) -> str:
    """The scenario callsign of a flight id: upper-case letters and digits, starting with a letter.

    Other characters are dropped; an id that then starts with a digit gets a ``UAM`` prefix.
    """
    cs = re.sub(r"[^A-Z0-9]", "", flight_id.upper())
    if cs and not cs[0].isalpha():
        cs = "UAM" + cs
    return cs


class _RowReader:
    """Validates rows one by one; keeps the state needed across rows."""

    def __init__(self, network: Network, columns: dict[str, tuple[int, float]], source: str):
        self.network = network
        self.columns = columns
        self.source = source
        self.reference_day: date | None = None
        self.callsigns: dict[str, int] = {}
        # Valid routes by (text, origin, destination): rows share a few hundred routes, so they
        # share the tuples too (and skip re-checking the segments).
        self.routes: dict[tuple[str, str, str], tuple[str, ...]] = {}

    def _cell(self, cells: list[str], name: str) -> str:
        spec = self.columns.get(name)
        if spec is None or spec[0] >= len(cells):
            return ""
        return cells[spec[0]].strip()

    def _factor(self, name: str) -> float:
        return self.columns[name][1] if name in self.columns else 1.0

    def read(self, row: int, cells: list[str]) -> tuple[ScheduledFlight | None, list[RowError]]:
        errors: list[RowError] = []

        def bad(fieldname: str, message: str) -> None:
            errors.append(RowError(self.source, row, fieldname, message))

        flight_id = self._cell(cells, "flight_id")
        callsign = callsign_for(flight_id)
        if not flight_id:
            bad("flight_id", "missing value")
        elif not callsign:
            bad("flight_id", f'"{flight_id}" has no letters or digits to make a callsign')
        elif len(callsign) > CALLSIGN_MAX_CHARS:
            bad("flight_id", f"gives a callsign of {len(callsign)} characters; at most {CALLSIGN_MAX_CHARS}")
        elif callsign in self.callsigns:
            bad(
                "flight_id", f'"{flight_id}" gives callsign {callsign}, already used on line {self.callsigns[callsign]}'
            )
        actype = self._cell(cells, "aircraft_type")
        problem = aircraft_type_problem(actype) if actype else None
        if problem:  # it is written into CRE lines: "EC35;ECHO ..." would be a second command
            bad("aircraft_type", problem)
        ends = {}
        for name in ("origin", "destination"):
            value = self._cell(cells, name)
            ends[name] = value
            if not value:
                bad(name, "missing value")
            elif value not in self.network.vertiports:
                bad(name, f'unknown vertiport "{value}"')
            else:
                ends[name] = sys.intern(value)  # one string per vertiport, not one per row
        origin, destination = ends["origin"], ends["destination"]
        if origin and origin == destination:
            bad("destination", f'"{destination}" is also the origin')
        times = {}
        for name in ("departure_time", "arrival_time"):
            text = self._cell(cells, name)
            if not text:
                if name == "departure_time":
                    bad(name, "missing value")
                times[name] = math.nan
                continue
            try:
                times[name], self.reference_day = parse_schedule_time(text, self._factor(name), self.reference_day)
            except TimeParseError as exc:
                bad(name, str(exc))
                times[name] = math.nan
        dep, arr = times["departure_time"], times["arrival_time"]
        if math.isfinite(dep) and math.isfinite(arr) and arr <= dep:
            bad("arrival_time", f"arrival {format_clock(arr)} is not after departure {format_clock(dep)}")
        speed = self._number(cells, "cruise_speed", bad, positive=True)
        alt = self._number(cells, "cruise_alt", bad, positive=False)
        route = self._route(cells, origin, destination, bad)
        passengers = None
        pax_text = self._cell(cells, "passengers")
        if pax_text:
            try:
                passengers = int(pax_text)
                if passengers < 0:
                    bad("passengers", f'"{pax_text}" is negative')
            except ValueError:
                bad("passengers", f'"{pax_text}" is not a whole number')
        cargo = self._number(cells, "cargo", bad, positive=False, optional=True)
        if errors:
            return None, errors
        self.callsigns[callsign] = row
        flight = ScheduledFlight(
            row,
            flight_id,
            callsign,
            sys.intern(self._cell(cells, "tail_id")),
            sys.intern(actype),
            origin,
            destination,
            dep,
            arr,
            route,
            speed,
            alt,
            passengers,
            None if math.isnan(cargo) else cargo,
        )
        return flight, []

    def _number(self, cells: list[str], name: str, report: Report, positive: bool, optional: bool = False) -> float:
        text = self._cell(cells, name)
        if not text:
            if not optional:
                report(name, "missing value")
            return math.nan
        try:
            value = float(text) * self._factor(name)
        except ValueError:
            report(name, f'"{text}" is not a number')
            return math.nan
        if not math.isfinite(value):
            report(name, f'"{text}" is not a finite number')
        elif positive and value <= 0:
            report(name, f'"{text}" must be positive')
        elif value < 0:
            report(name, f'"{text}" cannot be negative')
        return value

    def _route(self, cells: list[str], origin: str, destination: str, report: Report) -> tuple[str, ...]:
        text = self._cell(cells, "route")
        key = (text, origin, destination)
        cached = self.routes.get(key)
        if cached is not None:
            return cached
        errors: list[str] = []

        def note(fieldname: str, message: str) -> None:
            errors.append(message)
            report(fieldname, message)

        route = self._check_route(text, origin, destination, note)
        if not errors:
            self.routes[key] = route
        return route

    def _check_route(self, text: str, origin: str, destination: str, report: Report) -> tuple[str, ...]:
        tokens = [sys.intern(t) for t in _ROUTE_SPLIT.split(text) if t]
        if tokens and tokens[0] == origin:
            tokens = tokens[1:]
        if tokens and tokens[-1] == destination:
            tokens = tokens[:-1]
        net = self.network
        unknown = [t for t in tokens if not net.has_point(t)]
        for t in unknown:
            report("route", f'node "{t}" is not in the network')
        if unknown or origin not in net.vertiports or destination not in net.vertiports:
            return tuple(tokens)
        if not text:
            path = net.shortest_path(origin, destination)
            if path is None:
                report("route", f"no route in the network from {origin} to {destination}")
                return ()
            return tuple(path[1:-1])
        full = [origin, *tokens, destination]
        for a, b in pairwise(full):
            if net.segment(a, b) is None:
                report("route", f"no segment between {a} and {b} in the network")
                break
        return tuple(tokens)


def split_row(line: str) -> list[str]:
    """The cells of one CSV line (RFC 4180 quoting within the line).

    Raises:
        csv.Error: an unterminated quote (a quoted field cannot span lines).
    """
    if '"' not in line:  # the common case, and what the csv module would return
        return line.rstrip("\r\n").split(",")
    return next(csv.reader([line], strict=True))


def parse_schedule(stream: Iterable[str], network: Network, source: str = "<schedule>") -> Schedule:
    """Read a schedule from its lines (one row per line; line 1 is the header).

    Raises:
        ScheduleFormatError: the header row is missing or unusable.
    """
    lines = enumerate(stream, start=1)
    rows: _RowReader | None = None
    flights: list[ScheduledFlight] = []
    errors: list[RowError] = []
    count = 0
    for line, text in lines:
        if rows is None:
            try:
                headers = split_row(text)
            except csv.Error as exc:
                raise ScheduleFormatError(f"{source}:{line}: unreadable header ({exc})") from None
            rows = _RowReader(network, resolve_headers(headers, source), source)
            continue
        try:
            cells = split_row(text)
        except csv.Error as exc:
            errors.append(RowError(source, line, "*", f"unreadable CSV row ({exc}: a quote is not closed "
                                   "on this line)"))
            count += 1
            continue
        if not any(c.strip() for c in cells) or cells[0].lstrip().startswith("#"):
            continue
        count += 1
        flight, row_errors = rows.read(line, cells)
        if flight is not None:
            flights.append(flight)
        errors.extend(row_errors)
    if rows is None:
        raise ScheduleFormatError(f"{source}: the file is empty (no header row)")
    return Schedule(source, flights, errors, count)


_CR_SPLIT = re.compile(rb"(?<=\r)(?!\n)")  # after a lone CR (old Mac line ends)
_FALLBACK = "cp1252"


class _Lines:
    """The decoded lines of a schedule file, read lazily; ``warnings`` gathers the encoding notes."""

    def __init__(self, path: Path):
        self.path = path
        self.warnings: list[str] = []
        with open(path, "rb") as fh:
            head = fh.read(4)
        if head.startswith(codecs.BOM_UTF8):
            self.encoding = "utf-8-sig"
        elif head.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
            self.encoding = "utf-16"
        elif len(head) >= 2 and head[0] != 0 and head[1] == 0:  # ASCII text as UTF-16 without a BOM
            self.encoding = "utf-16-le"
        elif len(head) >= 2 and head[0] == 0 and head[1] != 0:
            self.encoding = "utf-16-be"
        else:
            self.encoding = "utf-8"

    def __iter__(self) -> Iterator[str]:
        if self.encoding.startswith("utf-16"):
            yield from self._utf16()
        else:
            yield from self._utf8()

    def _utf16(self) -> Iterator[str]:
        line = 0
        with open(self.path, encoding=self.encoding, newline="") as fh:
            try:
                for text in fh:
                    line += 1
                    yield text.lstrip("\ufeff") if line == 1 else text
            except UnicodeDecodeError as exc:
                raise ScheduleFormatError(f"{self.path}:{line + 1}: not valid {self.encoding} text ({exc.reason})") \
                    from None

    def _utf8(self) -> Iterator[str]:
        """UTF-8 line by line (exact: a newline byte never occurs inside a UTF-8 sequence)."""
        line, offset, fallback_lines = 0, 0, 0
        with open(self.path, "rb") as fh:
            for raw in fh:
                for part in _CR_SPLIT.split(raw) if b"\r" in raw.rstrip(b"\r\n") else (raw,):
                    line += 1
                    if line == 1 and part.startswith(codecs.BOM_UTF8):
                        part, offset = part[3:], offset + 3
                    try:
                        text = part.decode("utf-8")
                    except UnicodeDecodeError as exc:
                        if not fallback_lines:
                            self._warn_fallback(line, offset + exc.start, part[exc.start])
                        fallback_lines += 1
                        text = self._fallback(part)
                    offset += len(part)
                    yield text
        if fallback_lines > 1:
            self.warnings.append(f"{self.path}: {fallback_lines} lines in all were read as {_FALLBACK}")

    def _warn_fallback(self, line: int, offset: int, byte: int) -> None:
        msg = (f"{self.path}:{line}: byte 0x{byte:02X} at offset {offset} is not UTF-8; "
               f"this line and any other such line are read as {_FALLBACK}")
        log.warning("%s", msg)
        self.warnings.append(msg)

    @staticmethod
    def _fallback(part: bytes) -> str:
        try:
            return part.decode(_FALLBACK)
        except UnicodeDecodeError:  # the five bytes cp1252 leaves undefined: Latin-1 has them all
            return part.decode("latin-1")


def read_schedule(path: str | Path, network: Network) -> Schedule:
    """Read a schedule CSV file, line by line (see the module docstring for the encodings).

    Raises:
        ScheduleFormatError: the file cannot be read or its header is unusable.
    """
    path = Path(path)
    try:
        lines = _Lines(path)
        schedule = parse_schedule(lines, network, str(path))
    except OSError as exc:
        raise ScheduleFormatError(f"{path}: cannot read the schedule ({exc.strerror})") from None
    schedule.warnings.extend(lines.warnings)
    schedule.encoding = lines.encoding
    return schedule


def write_schedule(flights: Iterable[ScheduledFlight], out: IO[str]) -> int:
    """Write flights in the canonical format (the header of :data:`CANONICAL_HEADER`)."""
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(CANONICAL_HEADER)
    n = 0
    for fl in flights:
        writer.writerow(
            [
                fl.flight_id,
                fl.tail_id,
                fl.aircraft_type,
                fl.origin,
                fl.destination,
                format_clock(fl.departure_s),
                "" if math.isnan(fl.arrival_s) else format_clock(fl.arrival_s),
                " ".join([fl.origin, *fl.route, fl.destination]),
                f"{fl.cruise_speed_kts:.1f}",
                f"{fl.cruise_alt_ft:.0f}",
                "" if fl.passengers is None else fl.passengers,
                "" if fl.cargo_kg is None else f"{fl.cargo_kg:.1f}",
            ]
        )
        n += 1
    return n
