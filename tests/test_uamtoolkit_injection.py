"""uam2scn never turns data into commands (issue 26, item 3).

A network name, a vertiport name or a schedule's ``aircraft_type`` cell used to be written into the
scenario as it was: ``\\n00:00:00.00>PCALL ...`` in a name became a command line, ``EC35;ECHO ...``
chained a second command onto every ``CRE``. Every value that reaches the scenario is now checked
against an alphabet where it is read, and refused with its row or key.
"""

from __future__ import annotations

import copy
import io
import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from uam_helpers import GOOD_ROWS, HEADER, run_module

from aamsim import Simulation
from aamsim.stack.parser import parse_scenario
from uamtoolkit_import.convert import ConvertOptions, convert
from uamtoolkit_import.fields import comment_text
from uamtoolkit_import.netfile import NetworkError, nyc_network_path, parse_network
from uamtoolkit_import.schedule import parse_schedule

NET_DATA: dict[str, Any] = json.loads(nyc_network_path().read_text(encoding="utf-8"))
# What the three good rows convert into: one DEFWPT per used point, eight or nine commands per flight.
FLIGHT_COMMANDS = {"CRE", "ORIG", "DEST", "ADDWPT", "VNAV", "SPD", "RTA", "ATDIST"}


def _commands(text: str) -> list[str]:
    """The command names of a scenario as aamsim reads it (the ``ACID CMD`` form resolved)."""
    registry = Simulation(use_bluesky_navdata=False).commands
    parsed = parse_scenario(text, "x.scn", is_command=lambda name: name in registry)
    assert parsed.errors == []
    return [c.command.name for c in parsed.commands]


def _schedule(rows: list[str], network: Any) -> Any:
    return parse_schedule(io.StringIO("\n".join([HEADER, *rows]) + "\n"), network, "s.csv")


def _baseline_commands() -> list[str]:
    net = parse_network(NET_DATA, "net.json")
    return _commands(convert(_schedule(list(GOOD_ROWS), net), net, ConvertOptions(aircraft_type="SCHEDULE")).text)


BASELINE = _baseline_commands()


def test_the_baseline_is_only_flight_commands() -> None:
    assert set(BASELINE) == FLIGHT_COMMANDS | {"DEFWPT"} and BASELINE.count("CRE") == 3


@pytest.mark.parametrize("cell", ["EC35;ECHO pwned", "EC35 B744", "EC35,0,0", "EC35#", "A" * 17, "EC\u200b35"])
def test_an_aircraft_type_cell_that_is_not_a_type_refuses_its_row(cell: str) -> None:
    net = parse_network(NET_DATA, "net.json")
    rows = list(GOOD_ROWS)
    rows[1] = rows[1].replace("EVTOL4", cell if "," not in cell else f'"{cell}"')
    schedule = _schedule(rows, net)
    assert [(e.row, e.field) for e in schedule.errors] == [(3, "aircraft_type")]
    assert [f.flight_id for f in schedule.flights] == ["F1", "F3"]
    text = convert(schedule, net, ConvertOptions(aircraft_type="SCHEDULE")).text
    assert "ECHO" not in _commands(text) and _commands(text).count("CRE") == 2


def test_a_flight_id_giving_a_huge_callsign_refuses_its_row() -> None:
    net = parse_network(NET_DATA, "net.json")
    rows = [GOOD_ROWS[0].replace("F1,", "F" * 20_000 + ",", 1), *GOOD_ROWS[1:]]
    schedule = _schedule(rows, net)
    assert [(e.row, e.field) for e in schedule.errors] == [(2, "flight_id")]
    assert "at most 32" in str(schedule.errors[0])


@pytest.mark.parametrize("key, value", [
    ("name", "NYC\n00:00:00.00>PCALL /etc/passwd"),
    ("name", "NYC\r00:00:00.00>ECHO x"),
    ("vertiports.0.name", "Pier 6\n00:00:00.00>PCALL x.scn"),
    ("vertiports.0.name", "Pier 6\r\n00:00:00.00>ECHO x"),
    ("vertiports.0.name", "Pier 6\u2028x"),
    ("vertiports.0.id", "DMH\n00:00:00.00>ECHO x"),
    ("vertiports.0.kind", "heliport\x1b[2J"),
    ("nodes.0.corridor", "Hudson\n00:00:00.00>ECHO x"),
    ("nodes.0.id", "H" * 65),
    ("vertiports.0.name", "x" * 201),
])
def test_a_network_name_that_could_break_a_comment_line_is_refused_naming_its_key(key: str, value: str) -> None:
    data = copy.deepcopy(NET_DATA)
    parts = key.split(".")
    target: Any = data
    for part in parts[:-1]:
        target = target[int(part)] if part.isdigit() else target[part]
    target[parts[-1]] = value
    with pytest.raises(NetworkError) as info:
        parse_network(data, "net.json")
    where = key.replace(".0.", "[0].")
    assert str(info.value).startswith(f"net.json: {where}: ")


def test_the_cli_refuses_a_schedule_type_with_a_semicolon_and_writes_no_echo(tmp_path: Path) -> None:
    rows = list(GOOD_ROWS)
    rows[0] = rows[0].replace("EVTOL4", "EC35;ECHO pwned")
    src, out = tmp_path / "s.csv", tmp_path / "s.scn"
    src.write_text("\n".join([HEADER, *rows]) + "\n")
    proc = run_module("uamtoolkit_import", str(src), "-o", str(out), "--type", "SCHEDULE")
    assert proc.returncode == 0, proc.stderr
    assert f"{src}:2: field 'aircraft_type'" in proc.stderr and "2 flights written, 1 skipped" in proc.stdout
    assert "ECHO" not in out.read_text()


def test_the_cli_refuses_a_network_whose_name_holds_a_command(tmp_path: Path) -> None:
    data = copy.deepcopy(NET_DATA)
    data["vertiports"][0]["name"] = "Pier 6\n00:00:00.00>PCALL /etc/passwd"
    net, src, out = tmp_path / "n.json", tmp_path / "s.csv", tmp_path / "s.scn"
    net.write_text(json.dumps(data))
    src.write_text("\n".join([HEADER, *GOOD_ROWS]) + "\n")
    proc = run_module("uamtoolkit_import", str(src), "--network", str(net), "-o", str(out))
    assert proc.returncode != 0 and "vertiports[0].name: holds the control character U+000A" in proc.stderr
    assert not out.exists()


def test_a_schedule_path_with_a_line_break_stays_in_its_comment() -> None:
    net = parse_network(NET_DATA, "net.json")
    schedule = _schedule(list(GOOD_ROWS), net)
    schedule.path = "evil\n00:00:00.00>ECHO pwned\r.csv"
    assert _commands(convert(schedule, net).text) == _commands(convert(_schedule(list(GOOD_ROWS), net), net).text)
    assert comment_text("a\nb\u2028c") == "a\\x0ab\\u2028c"


_ANY_TEXT = st.one_of(
    st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=30),  # ; , # \\ > and spaces
    st.text(st.characters(blacklist_categories=("Cs",)), max_size=30),
    st.sampled_from(["x\n00:00:00.00>ECHO a", "x\r00:00:00.00>ECHO a", "EC35;ECHO a", "a,b", "a#b", "a\\", "B744"]),
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(network_name=_ANY_TEXT, vertiport_name=_ANY_TEXT, corridor=_ANY_TEXT, actype=_ANY_TEXT)
def test_whatever_the_names_the_scenario_holds_only_the_flight_commands(
        network_name: str, vertiport_name: str, corridor: str, actype: str) -> None:
    """Either a value is refused where it is read, or the scenario is the same commands as with plain values."""
    data = copy.deepcopy(NET_DATA)
    data["name"] = network_name
    data["vertiports"][0]["name"] = vertiport_name
    data["nodes"][0]["corridor"] = corridor
    try:
        net = parse_network(data, "net.json")
    except NetworkError:
        event("network refused")
        return
    cell = actype.replace('"', '""')
    rows = [row.replace("EVTOL4", f'"{cell}"') for row in GOOD_ROWS]
    if any(ch in actype for ch in "\r\n"):
        return  # a schedule row is one line: the cell cannot hold a line break
    schedule = _schedule(rows, net)
    text = convert(schedule, net, ConvertOptions(aircraft_type="SCHEDULE")).text
    commands = _commands(text)
    event("rows refused" if schedule.errors else "converted")
    if schedule.errors:
        assert {e.field for e in schedule.errors} == {"aircraft_type"} and "CRE" not in commands
    else:
        assert commands == BASELINE
