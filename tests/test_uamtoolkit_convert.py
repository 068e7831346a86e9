"""Schedule -> scenario text, and the ``uam2scn`` conversion command."""

from __future__ import annotations

import io
import re
from pathlib import Path

import pytest
from uam_helpers import GOOD_ROWS, HEADER, created_callsigns, run_module, write_csv

from aamsim import Simulation
from uamtoolkit_import.convert import ConvertOptions, convert, scenario_names
from uamtoolkit_import.netfile import nyc_network
from uamtoolkit_import.schedule import parse_schedule

NET = nyc_network()
NAMES = scenario_names(NET)


def schedule(rows=GOOD_ROWS):
    return parse_schedule(io.StringIO("\n".join([HEADER, *rows]) + "\n"), NET, "s.csv")


def flight_lines(text: str, callsign: str) -> list[str]:
    return [line for line in text.splitlines() if re.search(rf"\b{callsign}\b", line) and not line.startswith("#")]


def test_flight_block_follows_the_convention():
    text = convert(schedule(), NET, ConvertOptions(alt_noise_ft=0.0)).text
    lines = flight_lines(text, "F1")
    cmds = [line.split(">", 1)[1] for line in lines]
    assert all(line.startswith("08:00:00.00>") for line in lines)
    dmh, w30 = NAMES["DMH"], NAMES["W30"]
    assert cmds[0].startswith("CRE F1 EC35 40.701200 -74.009000 ") and cmds[0].endswith(" 500 0")
    assert cmds[1:] == [
        f"ORIG F1 {dmh}",
        f"DEST F1 {w30}",
        f"ADDWPT F1 {NAMES['HUD02']}",
        f"ADDWPT F1 {NAMES['HUD03']}",
        "VNAV F1 OFF",
        "SPD F1 120",
        f"RTA F1 {w30} 08:04:00.00",
        "F1 ATDIST 40.754700 -74.007600 0.05 DEL F1",
    ]
    # Every used point is defined once at the top, and only those.
    defined = re.findall(r"^00:00:00\.00>DEFWPT (\w+) ", text, flags=re.MULTILINE)
    used = {"DMH", "W30", "HUD02", "HUD03", "E34", "LGA", "ER06", "ER07", "ER08", "ER09", "ER10"}
    assert sorted(defined) == sorted(NAMES[p] for p in used)


def test_heading_points_to_the_first_waypoint():
    text = convert(schedule(), NET, ConvertOptions(alt_noise_ft=0.0)).text
    cre = next(line for line in flight_lines(text, "F1") if ">CRE " in line).split()
    assert float(cre[5]) == pytest.approx(338.4, abs=0.5)  # DMH -> HUD02 is north-north-west


def test_time_window_keeps_departures_inside_and_rebases():
    conv = convert(schedule(), NET, ConvertOptions(start_s=8 * 3600 + 60, end_s=8 * 3600 + 150))
    assert [f.flight_id for f in conv.written] == ["F2"] and conv.outside_window == 2
    lines = flight_lines(conv.text, "F2")
    assert lines[0].startswith("00:00:00.00>CRE F2 ")
    assert any(">RTA F2 " in line and line.endswith(" 00:04:00.00") for line in lines)
    # [start, end): a departure exactly at the end is out, exactly at the start is in.
    assert [f.flight_id for f in convert(schedule(), NET, ConvertOptions(8 * 3600, 8 * 3600 + 60)).written] == ["F1"]


def test_noise_is_bounded_seeded_and_the_same_in_every_window():
    rows = [f"N{k},T,X,DMH,W30,08:{k // 60:02d}:{k % 60:02d},,,100,1200,," for k in range(200)]
    sched = schedule(rows)

    def altitudes(options):
        text = convert(sched, NET, options).text
        return {line.split()[1]: float(line.split()[6]) for line in text.splitlines() if ">CRE " in line}

    a = altitudes(ConvertOptions(seed=5))
    assert len(a) == 200 and all(1100.0 <= x <= 1300.0 for x in a.values())
    assert max(a.values()) - min(a.values()) > 150  # it is noise, not a constant
    assert altitudes(ConvertOptions(seed=5)) == a
    assert altitudes(ConvertOptions(seed=6)) != a
    window = altitudes(ConvertOptions(seed=5, start_s=8 * 3600 + 100, end_s=8 * 3600 + 150))
    assert window == {k: a[k] for k in window} and len(window) == 50
    assert set(altitudes(ConvertOptions(alt_noise_ft=0.0)).values()) == {1200.0}


def test_same_seed_gives_an_identical_file():
    assert (
        convert(schedule(), NET, ConvertOptions(seed=3)).text == convert(schedule(), NET, ConvertOptions(seed=3)).text
    )


def test_aircraft_type_from_the_schedule():
    text = convert(schedule(), NET, ConvertOptions(aircraft_type="SCHEDULE")).text
    assert " EVTOL4 " in next(line for line in text.splitlines() if ">CRE F1 " in line)


def test_aamsim_parses_and_runs_the_produced_text():
    text = convert(schedule(), NET).text
    sim = Simulation(use_bluesky_navdata=False)
    parsed = sim.load_text(text, "conv.scn")
    assert parsed.errors == []
    sim.run()
    assert not [m for m in sim.reporter.messages if m.kind == "error"]
    arrived = {rec.acid: rec for rec in sim.flight_log}
    assert set(arrived) == {"F1", "F2", "F3"}
    assert all(rec.arrived for rec in arrived.values())
    assert arrived["F3"].destination == NAMES["LGA"] and arrived["F3"].origin == NAMES["E34"]


# ----------------------------------------------------------------------- CLI
def test_cli_default_command_writes_and_summarises(tmp_path: Path):
    bad = "B1,N1,X,DMH,W30,08:00,08:05,,abc,500,,"
    csv_path = write_csv(tmp_path / "s.csv", HEADER, [GOOD_ROWS[0], bad, GOOD_ROWS[1], GOOD_ROWS[2]])
    out = tmp_path / "out.scn"
    r = run_module(
        "uamtoolkit_import",
        str(csv_path),
        "--network",
        str(NET.source),
        "-o",
        str(out),
        "--start",
        "08:00",
        "--end",
        "08:02",
        "--seed",
        "1",
    )
    assert r.returncode == 0, r.stderr
    assert f"{csv_path}:3: field 'cruise_speed': \"abc\" is not a number" in r.stderr
    assert f"{out}: 2 flights written, 1 skipped, 1 outside the time window" in r.stdout
    assert created_callsigns(out.read_text()) == ["F1", "F2"]


def test_cli_strict_fails_listing_every_error(tmp_path: Path):
    rows = [GOOD_ROWS[0], "B1,N1,X,XYZ,W30,08:00,08:05,,100,500,,", "B2,N1,X,DMH,W30,08:00,08:05,,abc,500,,"]
    csv_path = write_csv(tmp_path / "s.csv", HEADER, rows)
    out = tmp_path / "out.scn"
    r = run_module("uamtoolkit_import", str(csv_path), "-o", str(out), "--strict")
    assert r.returncode == 2
    assert f"{csv_path}:3: field 'origin'" in r.stderr and f"{csv_path}:4: field 'cruise_speed'" in r.stderr
    assert "nothing written (--strict)" in r.stderr
    assert not out.exists()


def test_cli_bad_network_and_bad_header_exit_2(tmp_path: Path):
    csv_path = write_csv(tmp_path / "s.csv", HEADER, list(GOOD_ROWS))
    net = tmp_path / "net.json"
    net.write_text('{"vertiports": [{"id": "A", "lon": 1}], "segments": []}')
    r = run_module("uamtoolkit_import", str(csv_path), "--network", str(net), "-o", str(tmp_path / "o.scn"))
    assert r.returncode == 2 and f"error: {net}: vertiports[0]: missing key 'lat'" in r.stderr
    write_csv(csv_path, "flight_id,origin", ["F1,DMH"])
    r = run_module("uamtoolkit_import", str(csv_path), "-o", str(tmp_path / "o.scn"))
    assert r.returncode == 2 and "missing column(s)" in r.stderr
