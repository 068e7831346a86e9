"""Row sources: a file -> chunks of raw column values, never the whole file at once.

CSV is read row by row with the csv module, Parquet batch by batch with
``pyarrow.parquet.ParquetFile.iter_batches``, JSON lines line by line, and a top-level JSON
array of records (what ``DataFrame.to_json(orient="records")`` writes, e.g. the traffic
library's samples) with an incremental decoder over a sliding buffer. Only a single JSON
*object* (an OpenSky REST response, or pandas' default ``orient="columns"``) spread over
several lines is loaded at once.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from typing import Any, TextIO

from aamsim.extras import missing
from aamsim.realtraffic.columns import ColumnPlan
from aamsim.realtraffic.normalise import RawChunk
from aamsim.realtraffic.reports import RecordingError, SkipLog, SkippedRow

PlanFor = Callable[[Sequence[str]], ColumnPlan]

#: OpenSky REST ``states/all``: index in a state vector -> the SI column name it is read as.
#: (0 icao24, 1 callsign, 2 origin_country, 3 time_position, 4 last_contact, 5 longitude,
#: 6 latitude, 7 baro_altitude m, 8 on_ground, 9 velocity m/s, 10 true_track deg,
#: 11 vertical_rate m/s, 12 sensors, 13 geo_altitude m, 14 squawk, 15 spi, 16 position_source,
#: 17 category when asked for with extended=1.)
REST_LAYOUT = {
    0: "icao24", 1: "callsign", 3: "time", 5: "lon", 6: "lat", 7: "baroaltitude", 8: "onground",
    9: "velocity", 10: "true_track", 11: "vertrate", 13: "geo_altitude",
}
REST_FIELDS = 17
_AFTER_VALUE = frozenset(" \t\r\n,]")
#: Largest single JSON record accepted in an array before the file is called broken.
MAX_RECORD_CHARS = 1 << 22
# Python's decoder recurses once per nesting level: a deeply nested value ends in RecursionError,
# which used to end the run with no outputs.
_TOO_DEEP = "JSON nested too deep to be a state report"


def csv_chunks(path: str, stream: TextIO, plan_for: PlanFor, chunk_rows: int, skips: SkipLog) -> Iterator[RawChunk]:
    reader = csv.reader(stream)
    try:
        header = next(reader, None)
        if header is None:
            raise RecordingError(path, "empty file: no header line")
        plan = plan_for(header)
        index = {name: header.index(name) for name in plan.columns}
        columns: dict[str, list[str]] = {name: [] for name in plan.columns}
        lines: list[int] = []
        for row in reader:
            if len(row) != len(header):
                if row:  # the csv module returns [] for a blank line: nothing to report
                    reason = f"{len(row)} fields where the header has {len(header)}"
                    skips.add(SkippedRow(path, str(reader.line_num), reason))
                continue
            for name, values in columns.items():
                values.append(row[index[name]])
            lines.append(reader.line_num)
            if len(lines) >= chunk_rows:
                yield RawChunk(columns, len(lines), _line_where(lines))
                columns, lines = {name: [] for name in plan.columns}, []
    except csv.Error as err:
        raise RecordingError(path, f"line {reader.line_num}: not CSV: {err}") from err
    if lines:
        yield RawChunk(columns, len(lines), _line_where(lines))


def _line_where(lines: list[int]) -> Callable[[int], str]:
    return lambda i: str(lines[i])


class _RecordBatcher:
    """Collects JSON records (dicts) into chunks; re-plans when a record brings new keys."""

    def __init__(self, path: str, plan_for: PlanFor, chunk_rows: int, skips: SkipLog):
        self.path, self.plan_for, self.chunk_rows, self.skips = path, plan_for, chunk_rows, skips
        self.keys: dict[str, None] = {}  # ordered set
        self.plan: ColumnPlan | None = None
        self.records: list[Mapping[str, Any]] = []
        self.wheres: list[str] = []

    def add(self, record: Any, where: str) -> RawChunk | None:
        if not isinstance(record, dict):
            self.skips.add(SkippedRow(self.path, where, f"a JSON {type(record).__name__} where a record is expected"))
            return None
        if self.plan is None or any(key not in self.keys for key in record):
            self.keys.update(dict.fromkeys(record))
            self.plan = self.plan_for(list(self.keys))
        self.records.append(record)
        self.wheres.append(where)
        return self.flush() if len(self.records) >= self.chunk_rows else None

    def flush(self) -> RawChunk | None:
        if not self.records or self.plan is None:
            return None
        records, wheres = self.records, self.wheres
        columns = {name: [r.get(name) for r in records] for name in self.plan.columns}
        self.records, self.wheres = [], []
        return RawChunk(columns, len(records), lambda i: wheres[i])

    def add_all(self, items: Iterable[tuple[Any, str]]) -> Iterator[RawChunk]:
        for record, where in items:
            chunk = self.add(record, where)
            if chunk is not None:
                yield chunk
        last = self.flush()
        if last is not None:
            yield last


def rest_states(path: str, response: Mapping[str, Any], number: int, skips: SkipLog) -> Iterator[tuple[Any, str]]:
    """The state vectors of one ``states/all`` response as (record, "response:state")."""
    states = response.get("states")
    if states is None:  # OpenSky answers "states": null when no aircraft is in the box
        return
    if not isinstance(states, list):
        raise RecordingError(path, f"response {number}: 'states' is not a list")
    for k, state in enumerate(states, start=1):
        where = f"{number}:{k}"
        if not isinstance(state, list) or len(state) < REST_FIELDS:
            size = len(state) if isinstance(state, list) else type(state).__name__
            skips.add(SkippedRow(path, where, f"state vector of {size} fields, the layout has {REST_FIELDS}"))
            continue
        yield {name: state[i] for i, name in REST_LAYOUT.items()}, where


def json_chunks(
    path: str, stream: TextIO, plan_for: PlanFor, chunk_rows: int, skips: SkipLog, *, lines: bool = False
) -> Iterator[RawChunk]:
    """Any of the JSON forms (see the module docstring); ``lines``: the file says it is JSON lines
    (``.jsonl``, ``.ndjson``), so that even a broken first line is one skipped row."""
    batcher = _RecordBatcher(path, plan_for, chunk_rows, skips)
    if lines:
        yield from batcher.add_all(_lines_records(path, stream, skips))
        return
    first = _peek_nonblank(stream)
    if first == "[":
        yield from batcher.add_all((rec, str(n)) for n, rec in enumerate(_array_records(path, stream), start=1))
        return
    if first != "{":
        raise RecordingError(path, f"not JSON records: starts with {first!r}" if first else "empty file")
    start = stream.tell()
    head = stream.readline()
    try:
        json.loads(head)
    except RecursionError:
        raise RecordingError(path, f"line 1: {_TOO_DEEP}") from None
    except json.JSONDecodeError:
        # An object over several lines: the whole file is one document.
        try:
            document = json.loads(head + stream.read())
        except json.JSONDecodeError as err:
            raise RecordingError(path, f"broken JSON at line {err.lineno} column {err.colno}: {err.msg}") from err
        except RecursionError:
            raise RecordingError(path, _TOO_DEEP) from None
        yield from batcher.add_all(_object_records(path, document, 1, skips))
        return
    stream.seek(start)
    yield from batcher.add_all(_lines_records(path, stream, skips))


def _lines_records(path: str, stream: TextIO, skips: SkipLog) -> Iterator[tuple[Any, str]]:
    """JSON lines: each line a record or a whole REST response; a broken line is a skipped row."""
    for number, line in enumerate(stream, start=1):
        if not line.strip():
            continue
        try:
            value = json.loads(line)
        except json.JSONDecodeError as err:
            skips.add(SkippedRow(path, str(number), f"broken JSON: {err.msg}"))
            continue
        except RecursionError:
            skips.add(SkippedRow(path, str(number), _TOO_DEEP))
            continue
        yield from _line_records(path, value, number, skips)


def _line_records(path: str, value: Any, number: int, skips: SkipLog) -> Iterator[tuple[Any, str]]:
    if isinstance(value, dict) and "states" in value:
        yield from rest_states(path, value, number, skips)
    else:
        yield value, str(number)


def _object_records(path: str, document: Any, number: int, skips: SkipLog) -> Iterator[tuple[Any, str]]:
    """A single JSON object: a REST response, or pandas ``orient="columns"`` ({column: {index: value}})."""
    if isinstance(document, dict) and "states" in document:
        yield from rest_states(path, document, number, skips)
        return
    if isinstance(document, dict) and document and all(isinstance(v, dict) for v in document.values()):
        index: dict[str, None] = {}
        for values in document.values():
            index.update(dict.fromkeys(values))
        for n, key in enumerate(index, start=1):
            yield {column: values.get(key) for column, values in document.items()}, str(n)
        return
    raise RecordingError(
        path, "a JSON object that is neither an OpenSky states response nor pandas orient='columns' records"
    )


def _peek_nonblank(stream: TextIO) -> str:
    """The first non-blank character, leaving the stream positioned on it."""
    while True:
        position = stream.tell()
        char = stream.read(1)
        if not char or not char.isspace():
            stream.seek(position)
            return char


def _array_records(path: str, stream: TextIO, block: int = 1 << 20) -> Iterator[Any]:
    """The elements of a top-level JSON array, decoded one at a time from a sliding buffer."""
    decoder = json.JSONDecoder()
    buf, pos, eof = stream.read(block), 0, False

    def fill() -> None:
        nonlocal buf, pos, eof
        more = stream.read(block)
        eof = not more
        buf, pos = buf[pos:] + more, 0

    def skip_blanks() -> str:
        nonlocal pos
        while True:
            while pos < len(buf) and buf[pos].isspace():
                pos += 1
            if pos < len(buf) or eof:
                return buf[pos] if pos < len(buf) else ""
            fill()

    if skip_blanks() != "[":
        raise RecordingError(path, "not a JSON array")
    pos += 1
    count = 0
    while True:
        char = skip_blanks()
        if char == "]":
            return
        if count:
            if char != ",":
                raise RecordingError(path, f"broken JSON array after record {count}: {char!r} where ',' or ']' is expected")
            pos += 1
            skip_blanks()
        while True:
            try:
                value, end = decoder.raw_decode(buf, pos)
            except json.JSONDecodeError as err:
                value, end = err, -1
            except RecursionError:
                raise RecordingError(path, f"record {count + 1}: {_TOO_DEEP}") from None
            # A value is complete once what follows it can only follow a value: a number cut at
            # the end of the buffer ("12" of "12.5") decodes too early otherwise.
            if end != -1 and (eof or (end < len(buf) and buf[end] in _AFTER_VALUE)):
                break
            if eof:
                raise RecordingError(path, f"broken JSON in record {count + 1}: {value}")
            if len(buf) - pos > MAX_RECORD_CHARS:
                raise RecordingError(path, f"record {count + 1} is over {MAX_RECORD_CHARS} characters: not records")
            fill()
        pos = end
        count += 1
        yield value
        if pos > block:  # drop what is decoded so the buffer stays about one block long
            buf, pos = buf[pos:], 0


def parquet_chunks(path: str, plan_for: PlanFor, chunk_rows: int) -> Iterator[RawChunk]:
    if missing(("pyarrow",)):
        raise RecordingError(path, 'reading Parquet needs pyarrow, which is not installed: '
                                   'pip install "aamsim[realtraffic]"')
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        parquet = pq.ParquetFile(path)
    except (pa.ArrowInvalid, OSError) as err:
        raise RecordingError(path, f"not a Parquet file: {err}") from err
    plan = plan_for(parquet.schema_arrow.names)
    first_row = 0
    for batch in parquet.iter_batches(batch_size=chunk_rows, columns=plan.columns):
        columns = {name: _arrow_values(pa, batch.column(name)) for name in plan.columns}
        yield RawChunk(columns, batch.num_rows, _row_where(first_row))
        first_row += batch.num_rows


def _row_where(first_row: int) -> Callable[[int], str]:
    return lambda i: str(first_row + i + 1)


def _arrow_values(pa: Any, column: Any) -> Any:
    """Numbers as a numpy array (nulls -> NaN), timestamps as float s since the epoch, the rest as a list."""
    kind = column.type
    if pa.types.is_timestamp(kind):
        nanoseconds = column.cast(pa.timestamp("ns", tz=kind.tz)).cast(pa.int64())
        return nanoseconds.to_numpy(zero_copy_only=False) / 1e9
    if pa.types.is_floating(kind) or pa.types.is_integer(kind):
        return column.to_numpy(zero_copy_only=False)
    return column.to_pylist()


def rest_response_chunks(
    path: str, response: Mapping[str, Any], number: int, plan_for: PlanFor, skips: SkipLog
) -> Iterator[RawChunk]:
    """One decoded ``states/all`` response (a live poll: ``path`` names its source, ``number`` the poll)."""
    batcher = _RecordBatcher(path, plan_for, 1 << 30, skips)
    yield from batcher.add_all(rest_states(path, response, number, skips))
