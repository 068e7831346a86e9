"""When a run without ``--until`` ends (issue 26 item 9b, aamsim/run_end.py), and the warning about
BlueSky's airliner protected zone on rotorcraft traffic (item 9c, aamsim/conflicts/zone_advice.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from aamsim import Simulation
from aamsim.run_end import DEFAULT_HORIZON_S, STALL_LIMIT_S

ROOT = Path(__file__).resolve().parents[1]


class RanTooLong(Exception):
    pass


def run_open_ended(text: str, cap_s: float = 5 * 86_400.0) -> Simulation:
    """``sim.run()`` without an end time; raises RanTooLong past ``cap_s`` (a run that would never end)."""
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.services.start()
    sim.load_text(text)

    def cap(s: Simulation) -> None:
        if s.simt > cap_s:
            raise RanTooLong(f"still running at {s.simt:.0f} s")

    sim.run(progress=cap)
    return sim


def notes(sim: Simulation) -> list[str]:
    return [m.text for m in sim.reporter.messages if m.kind == "note"]


def test_a_hovering_aircraft_on_a_route_ends_the_run_after_an_hour_without_progress():
    # Speed 0 with a route: LNAV on for ever and the ATDIST point never reached. Before, such a run
    # never ended (an aircraft on a route kept it going whatever it did).
    sim = run_open_ended("00:00:00.00>CRE A EC35 40.7 -74.0 0 1500 0\n"
                         "00:00:00.00>ADDWPT A 40.8 -74.0\n"
                         "00:00:00.00>A ATDIST 40.8 -74.0 0.05 DEL A\n")
    assert sim.ended_by == "no_progress"
    assert STALL_LIMIT_S <= sim.simt <= STALL_LIMIT_S + 60.0  # checked every minute
    assert any("nothing progressed for 3600 s" in t and "1 aircraft still flying" in t and
               "1 conditional command(s) never fired" in t and "--until" in t for t in notes(sim))


def test_an_aircraft_creeping_along_its_route_stops_at_the_default_horizon():
    # 5 kt towards a waypoint 1,000 km away: progress every check, 4.6 days to get there.
    sim = run_open_ended("00:00:00.00>CRE A EC35 40.7 -74.0 0 1500 5\n"
                         "00:00:00.00>ADDWPT A 49.7 -74.0\n"
                         "00:00:10.00>ECHO last command\n")
    assert sim.ended_by == "horizon"
    assert 10.0 + DEFAULT_HORIZON_S <= sim.simt <= 10.0 + DEFAULT_HORIZON_S + 60.0
    assert any("the default horizon, 24 h after the last command (at 10 s)" in t for t in notes(sim))


def test_a_long_leg_is_flown_to_its_end():
    # 400 km at 120 kt, about 1.8 h on one leg: approaching its waypoint all the time, never cut short.
    sim = run_open_ended("00:00:00.00>CRE A EC35 40.7 -74.0 0 1500 120\n"
                         "00:00:00.00>ADDWPT A 44.3 -74.0\n"
                         "00:00:00.00>A ATDIST 44.3 -74.0 0.05 DEL A\n")
    assert sim.ended_by == "nothing_left" and sim.view.n == 0
    assert next(f.deleted_s for f in sim.flights()) > 1.5 * 3600


def test_commands_still_queued_keep_the_run_going():
    sim = run_open_ended("00:00:00.00>CRE A EC35 40.7 -74.0 0 1500 0\n"
                         "00:00:00.00>ADDWPT A 40.8 -74.0\n"
                         "03:00:00.00>DEL A\n")
    assert sim.view.n == 0 and sim.ended_by == "nothing_left" and 3 * 3600 <= sim.simt <= 3 * 3600 + 60


def test_until_overrides_the_default_stop(tmp_path: Path):
    scn = tmp_path / "hover.scn"
    scn.write_text("00:00:00.00>CRE A EC35 40.7 -74.0 0 1500 0\n00:00:00.00>ADDWPT A 40.8 -74.0\n")
    runs = {}
    for name, extra in (("open", []), ("until", ["--until", "02:00:00"])):
        proc = subprocess.run([sys.executable, "-m", "aamsim", "run", str(scn), "--out", str(tmp_path / name),
                               "--log-period", "0", *extra], capture_output=True, text=True, timeout=600,
                              env=dict(os.environ, PYTHONPATH=str(ROOT)), check=False)
        assert proc.returncode == 0, proc.stderr
        runs[name] = (json.loads((tmp_path / name / "summary.json").read_text()), proc.stderr)
    summary, stderr = runs["open"]
    assert summary["ended_by"] == "no_progress" and summary["sim_time_s"] <= STALL_LIMIT_S + 60
    assert "note: stopped at sim time" in stderr and "use --until to run longer" in stderr
    summary, _ = runs["until"]
    assert summary["ended_by"] == "until" and summary["sim_time_s"] == 7200.0


# ------------------------------------------------------------------------------- the zone warning
ROTOR_PAIR = ("00:00:00.00>CRE A EC35 40.7 -74.0 90 1500 100\n"
              "00:00:00.00>CRE B EC35 40.7 -73.9 270 1500 100\n")


def zone_warnings(text: str) -> list[str]:
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.services.start()
    sim.load_text(text)
    sim.run_until(5.0)
    return [m.text for m in sim.reporter.messages if m.kind == "warning" and "ZONER" in m.text]


def test_the_airliner_zone_on_rotorcraft_is_warned_about_once():
    warnings = zone_warnings("00:00:00.00>ASAS ON\n00:00:00.00>RESO MVP\n" + ROTOR_PAIR)
    assert len(warnings) == 1
    text = warnings[0]
    assert "BlueSky's airliner protected zone (5 NM / 1000 ft" in text and "2 of 2 aircraft" in text
    assert "RESO MVP pushes aircraft up to 5 NM off their routes" in text
    assert "ZONER 0.243" in text and "ZONEDH" in text


@pytest.mark.parametrize("text", [
    ROTOR_PAIR,  # detection off: nothing to warn about
    "00:00:00.00>ASAS ON\n00:00:00.00>ZONER 0.243\n00:00:00.00>ZONEDH 1476\n" + ROTOR_PAIR,  # a zone was chosen
    ("00:00:00.00>ASAS ON\n00:00:00.00>CRE A A320 40.7 -74.0 90 FL300 450\n"  # airliners: the zone fits
     "00:00:00.00>CRE B A320 40.7 -73.5 270 FL300 450\n"),
])
def test_no_zone_warning_when_the_zone_fits_or_detection_is_off(text):
    assert zone_warnings(text) == []
