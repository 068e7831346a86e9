"""Fuzzing the files other tools and people write: BlueSky batch files and uam2scn's schedules and networks.

Batch files: ``SCEN`` blocks with names drawn from paths (``../../x``, ``/tmp/x``, ``..``), control and
unicode characters, very long names and duplicates, and ``--set`` values drawn good, edge and absurd. A
failure is an exception other than :class:`~aamsim.batch.BatchError`, a run folder outside the batch
folder, or two jobs sharing a folder. Every ``run_every``-th file is also run (``aamsim batch --no-ray``'s
code, in this process) and the files written are checked to lie inside ``--out``.

uam2scn fields: a network and a schedule whose names, ids, corridors, prefixes, flight ids, aircraft
types, routes, times and numbers are drawn the same way. A failure is an exception other than the
converter's own errors, or a scenario that holds a command other than the flight commands uam2scn
writes (data turned into commands), or a line aamsim cannot parse.
"""

from __future__ import annotations

import copy
import csv
import io
import json
import random
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from aamsim import Simulation
from aamsim.stack.parser import parse_scenario
from tests.fuzz.scenario import Failure

NASTY = ["..", ".", "/tmp/x", "../../../../tmp/x", "a/../../b", "\\..\\x", "", " ", "\x00", "\n", "\r",
         "\r\n00:00:00.00>ECHO injected", "\n00:00:00.00>PCALL /etc/passwd", "EC35;ECHO x", "EC35,0,0", "#", ";",
         ">", "\\", '"', "'", "\u2028", "\u202e", "\x1b[2J", "🚁", "é", "x" * 300, "A" * 40, "CON", "nul",
         "-rf", "$(id)", "%0", "ONE", "TWO"]


def nasty_text(rng: random.Random) -> str:
    """A value for a name or a cell: nasty, random characters, or a combination."""
    r = rng.random()
    if r < 0.4:
        return rng.choice(NASTY)
    if r < 0.7:
        return "".join(chr(rng.choice([rng.randint(0, 0x7F), rng.randint(0x80, 0x2FFF)]))
                       for _ in range(rng.randint(0, 12)))
    if r < 0.85:
        return rng.choice(NASTY) + rng.choice(NASTY)
    return rng.choice(["ONE", "EC35", "DMH", "UAM1", "F1", "N001"])


# ---------------------------------------------------------------- batch files
SET_KEYS = ["dt", "until", "nmac", "lowc", "log_period", "delete_on_arrival", "stack", "wind", ""]
SET_VALUES = ["0.05", "1e300", "0", "-1", "nan", "inf", "1e-9", "01:00:00", "9" * 400, "450", "450,76", "x",
              "true", "maybe", "ZONER 0.3", "ECHO hi", "", "/etc/passwd"]


def batch_case(rng: random.Random) -> tuple[str, list[str]]:
    """A batch file's text and --set items."""
    blocks = []
    for k in range(rng.randint(0, 5)):
        name = nasty_text(rng) if rng.random() < 0.85 else ""
        name = name.replace("\n", " ").replace("\r", " ")  # a name is one line's word (else it is a new line)
        blocks.append(f"00:00:00.00>SCEN {name}\n00:00:00.00>CRE A{k} B744 0 0 0 FL100 250\n00:00:02.00>QUIT\n")
    if rng.random() < 0.2:
        blocks.insert(0, "00:00:00.00>CRE STRAY B744 0 0 0 FL100 250\n")
    sets = [f"{rng.choice(SET_KEYS)}={rng.choice(SET_VALUES)}" for _ in range(rng.randint(0, 3))]
    return "".join(blocks) or "00:00:00.00>CRE A B744 0 0 0 FL100 250\n", sets


REFUSED = "refused"  # the tool refused the input with its own error: what bad input should get


def check_batch(text: str, sets: list[str], folder: Path, run: bool) -> str | None:
    """None when the batch file is planned (and run) as promised, REFUSED, or what went wrong."""
    from aamsim.batch import BatchError, load_sources, parse_settings, plan_jobs, run_batch

    path = folder / "b.scn"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        sources, _ = load_sources([path])
        settings = parse_settings(sets)
    except BatchError:
        return REFUSED
    jobs = plan_jobs(sources, settings, [0], base={"log_period_s": 0.0, "until_s": 2.0})
    out = (folder / "out").resolve()
    dirs = [(out / j.relpath).resolve() for j in jobs]
    if any(not d.is_relative_to(out) for d in dirs):
        return f"a run folder outside --out: {[j.relpath for j in jobs]}"
    if len(set(dirs)) != len(dirs):
        return f"two runs share a folder: {[j.relpath for j in jobs]}"
    if run:
        before = {p.resolve() for p in folder.parent.rglob("*")}
        run_batch(jobs, folder / "out", use_ray=False)
        after = {p.resolve() for p in folder.parent.rglob("*")} - before
        strays = [p for p in after if not p.is_relative_to(folder.resolve())]
        if strays:
            return f"files written outside the batch folder: {strays[:3]}"
    return None


# ---------------------------------------------------------------- uam2scn fields
SCHEDULE_HEADER = ("flight_id,tail_id,aircraft_type,origin,destination,departure_time,arrival_time,route,"
                   "cruise_speed_kts,cruise_alt_ft,passengers,cargo_kg")
GOOD_ROWS = [
    ["F1", "N001", "EVTOL4", "DMH", "W30", "08:00:00", "08:04:00", "DMH HUD02 HUD03 W30", "120", "500", "2", "10"],
    ["F2", "N002", "EVTOL4", "W30", "DMH", "08:01:00", "08:05:00", "HUD03 HUD02", "100", "1200", "1", "0"],
    ["F3", "N003", "EVTOL4", "E34", "LGA", "08:02:30", "08:09:00", "ER06 ER07 ER08 ER09 ER10", "140", "500", "3",
     "45.5"],
]
FLIGHT_COMMANDS = {"CRE", "ORIG", "DEST", "ADDWPT", "VNAV", "SPD", "RTA", "ATDIST", "DEFWPT"}
NETWORK_KEYS = [("name",), ("scenario_prefix",), ("vertiports", 0, "name"), ("vertiports", 0, "id"),
                ("vertiports", 1, "kind"), ("nodes", 0, "corridor"), ("nodes", 1, "id"), ("segments", 0, "corridor")]


def uam2scn_case(rng: random.Random, network: dict[str, Any]) -> tuple[dict[str, Any], str]:
    """A network (the New York one with a few fields replaced) and a schedule CSV text."""
    data = copy.deepcopy(network)
    for _ in range(rng.randint(0, 3)):
        key = rng.choice(NETWORK_KEYS)
        target: Any = data
        for part in key[:-1]:
            target = target[part]
        target[key[-1]] = nasty_text(rng)
    rows = [list(r) for r in GOOD_ROWS]
    for _ in range(rng.randint(0, 6)):
        rows[rng.randrange(len(rows))][rng.randrange(len(SCHEDULE_HEADER.split(",")))] = nasty_text(rng)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(SCHEDULE_HEADER.split(","))
    writer.writerows(rows)
    return data, buf.getvalue()


def check_uam2scn(data: dict[str, Any], schedule_text: str, is_command: Callable[[str], bool]) -> str | None:
    """None when the converter writes only flight commands, REFUSED, or what went wrong."""
    from uamtoolkit_import.convert import ConvertOptions, convert
    from uamtoolkit_import.headers import ScheduleFormatError
    from uamtoolkit_import.netfile import NetworkError, parse_network
    from uamtoolkit_import.schedule import parse_schedule

    try:
        net = parse_network(data, "net.json")
        # A row is one line: a cell with a line break is a file the reader splits (the csv writer quoted it).
        schedule = parse_schedule(io.StringIO(schedule_text, newline=None), net, "s.csv")
    except (NetworkError, ScheduleFormatError):
        return REFUSED
    text = convert(schedule, net, ConvertOptions(aircraft_type="SCHEDULE")).text
    parsed = parse_scenario(text, "x.scn", is_command=is_command)
    if parsed.errors:
        return f"the scenario has lines aamsim cannot read: {parsed.errors[0]}"
    names = {c.command.name for c in parsed.commands}
    if not names <= FLIGHT_COMMANDS:
        return f"data became commands: {sorted(names - FLIGHT_COMMANDS)}"
    cre = sum(1 for c in parsed.commands if c.command.name == "CRE")
    if cre != len(schedule.flights):
        return f"{len(schedule.flights)} flights but {cre} CRE lines"
    return None


# ---------------------------------------------------------------- the runs
@dataclass
class FileFuzzResult:
    target: str
    cases: int = 0
    refused: int = 0  # cases the tool refused with its own error (as it should, for bad input)
    failures: list[Failure] = field(default_factory=list)


def fuzz_batch(cases: int, seed: int = 0, run_every: int = 25) -> FileFuzzResult:
    rng = random.Random(seed)
    result = FileFuzzResult("batch")
    with tempfile.TemporaryDirectory() as top:
        for k in range(cases):
            text, sets = batch_case(rng)
            folder = Path(top) / f"case{k}"
            folder.mkdir()
            try:
                problem = check_batch(text, sets, folder, run=k % run_every == 0)
            except Exception as exc:  # noqa: BLE001 - that is what the harness looks for
                problem = f"crash: {type(exc).__name__}: {exc}"[:500]
            _tally(result, problem, partial(dict, file=text, set=sets))
    return result


def _tally(result: FileFuzzResult, problem: str, case: Callable[[], object]) -> None:
    """Count one case: refused by the tool, failed (``case()`` is the input, as JSON), or passed."""
    if problem == REFUSED:
        result.refused += 1
    elif problem:
        result.failures.append(Failure("crash" if problem.startswith("crash") else "wrong", json.dumps(case()),
                                       problem, 0.0))
    result.cases += 1


def _uam2scn_input(network: dict[str, Any], data: dict[str, Any], schedule_text: str) -> dict[str, Any]:
    return {"network_changes": _changes(network, data), "schedule": schedule_text}


def fuzz_uam2scn(cases: int, seed: int = 0) -> FileFuzzResult:
    from uamtoolkit_import.netfile import nyc_network_path

    rng = random.Random(seed)
    network = json.loads(nyc_network_path().read_text(encoding="utf-8"))
    registry = Simulation(use_bluesky_navdata=False).commands
    result = FileFuzzResult("uam2scn")
    for _ in range(cases):
        data, schedule_text = uam2scn_case(rng, network)
        try:
            problem = check_uam2scn(data, schedule_text, registry.__contains__)
        except Exception as exc:  # noqa: BLE001 - that is what the harness looks for
            problem = f"crash: {type(exc).__name__}: {exc}"[:500]
        _tally(result, problem, partial(_uam2scn_input, network, data, schedule_text))
    return result


def _changes(before: dict[str, Any], after: dict[str, Any]) -> dict[str, Any]:
    """The network fields a case replaced (for its report)."""
    out: dict[str, Any] = {}
    for key in NETWORK_KEYS:
        a: Any = before
        b: Any = after
        for part in key:
            a, b = a[part], b[part]
        if a != b:
            out[".".join(map(str, key))] = b
    return out
