"""Each stack command, with its effect on the state and its errors."""

from __future__ import annotations

import math

import pytest
from conftest import errors_of

from aamsim import Simulation
from aamsim.aero import cas2tas
from aamsim.traffic import fields as f
from aamsim.units import FPM, FT, KTS, NM


def test_cre_defaults_and_units(sim):
    sim.stack("CRE KL1 EC35 N40'42'00 W074'00'00 090 FL015 120")
    i = sim.view.slot("kl1")
    assert sim.view.lat[i] == pytest.approx(40.7)
    assert sim.view.lon[i] == pytest.approx(-74.0)
    assert sim.view.alt[i] == pytest.approx(1500 * FT)
    assert sim.view.cas[i] == pytest.approx(120 * KTS)
    sim.stack("CRE KL2,EC35,40,-74")
    j = sim.view.slot("KL2")
    assert sim.view.alt[j] == 0.0 and sim.view.tas[j] == 0.0 and sim.view.hdg[j] == 0.0


def test_cre_unknown_type_warns_once_and_uses_default(sim):
    sim.stack("CRE A XYZ1 0 0 0 1000 100")
    sim.stack("CRE B XYZ1 0 1 0 1000 100")
    notes = [m for m in sim.reporter.messages if "XYZ1" in m.text]
    assert len(notes) == 1 and "B744" in notes[0].text
    assert sim.view.types == ("XYZ1", "XYZ1")


def test_del_star_all_and_unknown(sim):
    sim.stack("CRE A EC35 0 0 0 1000 100; CRE B EC35 0 1 0 1000 100")
    assert not sim.stack("DEL ALL")
    assert "DEL *" in errors_of(sim)[-1]
    assert sim.view.n == 2
    sim.stack("DEL *")
    assert sim.view.n == 0


def test_spd_alt_vs_hdg_set_autopilot(sim):
    sim.stack("CRE A EC35 0 0 0 1000 100")
    sim.stack("SPD A 80; ALT A FL020 800; HDG A 270")
    F, B = sim._traffic.F, sim._traffic.B
    assert F[f.SELSPD, 0] == pytest.approx(80 * KTS) and not B[f.B_SELSPD_MACH, 0]
    assert F[f.SELALT, 0] == pytest.approx(2000 * FT) and F[f.SELVS, 0] == pytest.approx(800 * FPM)
    assert F[f.AP_TRK, 0] == 270.0 and not B[f.B_SWLNAV, 0]
    sim.stack("SPD A M0.2")
    assert B[f.B_SELSPD_MACH, 0] and F[f.SELSPD, 0] == 0.2
    # ALT below with an upward V/S selected drops that V/S (default 1500 fpm used).
    sim.stack("ALT A 500")
    assert F[f.SELVS, 0] == 0.0


def test_addwpt_names_constraints_and_insertion(sim):
    sim.stack("CRE A EC35 0 0 0 1000 100")
    sim.stack("ADDWPT A 0.1 0 2000 90")
    sim.stack("DEFWPT FIX1 0.2 0")
    sim.stack("ADDWPT A FIX1")
    sim.stack("DEST A 0.3 0")
    sim.stack("ADDWPT A 0.15 0,,, A001")
    route = sim._traffic.routes[0]
    assert route.names == ["A001", "A002", "FIX1", "0.300000,0.000000"]
    assert route.waypoints[0].alt == pytest.approx(2000 * FT)
    assert route.waypoints[0].spd == pytest.approx(90 * KTS)
    assert math.isnan(route.waypoints[1].alt)
    assert route.waypoints[-1].alt == 0.0
    assert sim._traffic.B[f.B_SWLNAV, 0] and route.iactwp == 0


def test_addwpt_flyover_mode_and_unsupported_modes(sim):
    sim.stack("CRE A EC35 0 0 0 1000 100")
    sim.stack("ADDWPT A FLYOVER")
    sim.stack("ADDWPT A 0.1 0")
    assert not sim._traffic.routes[0].waypoints[0].flyby
    assert not sim.stack("ADDWPT A TAKEOFF")
    assert "not supported" in errors_of(sim)[-1]


def test_addwpt_turn_modes_and_values(sim):
    sim.stack("CRE A EC35 0 0 0 1000 100")
    route = sim._traffic.routes[0]
    for line in ("ADDWPT A FLYTURN", "ADDWPT A 0.1 0", "ADDWPT A TURNSPD 30", "A ADDWPT TURNRAD 0.5",
                 "ADDWPT A 0.2 0", "ADDWPT A TURNBANK 120", "ADDWPT A 0.3 0", "ADDWPT A TURNRAD OFF",
                 "ADDWPT A 0.4 0", "ADDWPT A FLY-BY", "ADDWPT A 0.5 0"):
        assert sim.stack(line), (line, errors_of(sim))
    turns = [w.turn for w in route.waypoints]
    assert turns[0] is not None and turns[0].given() == ()  # FLYTURN with nothing given
    assert turns[1].speed_cas == pytest.approx(30 * KTS) and turns[1].radius_m == pytest.approx(0.5 * NM)
    # A third value drops the oldest (the speed); the bank is limited to 90 deg.
    assert turns[2].given() == ("bank", "radius") and turns[2].bank_deg == 90.0
    assert turns[3].given() == ("bank",)
    assert turns[4] is None and route.waypoints[4].flyby
    for bad in ("ADDWPT A TURNSPD", "ADDWPT A TURNRAD x", "ADDWPT A TURNBANK 10 20"):
        assert not sim.stack(bad), bad
    assert sim.stack("ADDWPTMODE A") and sim.reporter.messages[-1].text == "Current ADDWPT mode is FLYBY."
    assert sim.stack("ADDWPTMODE A TURNSPD 20") and route.mode == "FLYTURN"
    assert not sim.stack("ADDWPTMODE A SIDEWAYS")
    sim.stack("DELRTE A")
    assert route.mode == "FLYBY" and route.turn_values.given() == ()


def test_direct_delwpt_delrte_lnav_vnav(sim):
    sim.stack("CRE A EC35 0 0 0 1000 100")
    for k in range(1, 4):
        sim.stack(f"ADDWPT A {0.1 * k} 0")
    sim.stack("DIRECT A A003")
    assert sim._traffic.routes[0].iactwp == 2
    sim.stack("DELWPT A A002")
    assert sim._traffic.routes[0].names == ["A001", "A003"]
    assert not sim.stack("DELWPT A NOPE")
    sim.stack("LNAV A OFF")
    assert not sim._traffic.B[f.B_SWLNAV, 0]
    assert not sim.stack("VNAV A ON")  # needs LNAV
    sim.stack("LNAV A ON; VNAV A ON")
    assert sim._traffic.B[f.B_SWLNAV, 0] and sim._traffic.B[f.B_SWVNAV, 0]
    sim.stack("DELRTE A")
    assert len(sim._traffic.routes[0]) == 0 and not sim._traffic.B[f.B_SWLNAV, 0]


def test_orig_dest_bookkeeping(sim):
    sim.stack("CRE A EC35 0 0 0 1000 100; DEFWPT VPA 0 0; DEFWPT VPB 0.2 0")
    sim.stack("ORIG A VPA; DEST A VPB")
    rec = sim._traffic.flights[0]
    assert rec.origin == "VPA" and rec.destination == "VPB"
    route = sim._traffic.routes[0]
    assert route.names == ["VPA", "VPB"] and route.iactwp == 1
    assert sim._traffic.B[f.B_SWVNAV, 0]


def test_at_constraints_and_do_commands(sim):
    sim.stack("CRE A EC35 0 0 0 1000 100; ADDWPT A 0.01 0; ADDWPT A 0.05 0")
    sim.stack("A AT A001 DO SPD 60")
    sim.stack("AT A A002 FL020/80")
    route = sim._traffic.routes[0]
    assert route.waypoints[0].stack == ["SPD A 60"]
    assert route.waypoints[1].alt == pytest.approx(2000 * FT)
    assert route.waypoints[1].spd == pytest.approx(80 * KTS)
    sim.run_until(60.0)
    assert sim._traffic.F[f.SELSPD, 0] == pytest.approx(60 * KTS)
    sim.stack("AT A A002 DEL BOTH")
    assert math.isnan(route.waypoints[1].alt) and math.isnan(route.waypoints[1].spd)


def test_conditional_commands_fire_once(sim):
    sim.load_text(
        "00:00:00.00>CRE A EC35 0 0 0 1000 100\n"
        "00:00:00.00>ALT A 2000\n"
        "00:00:00.00>A ATALT 1500 SPD A 50\n"
        "00:00:00.00>A ATSPD 60 ECHO slowed\n"
        "00:00:00.00>A ATDIST 0.1 0 1 DEL A\n"
    )
    sim.run_until(30.0)
    assert sim._traffic.F[f.SELSPD, 0] == pytest.approx(50 * KTS)
    assert sum(m.text == "slowed" for m in sim.reporter.messages) == 1
    sim.run_until(400.0)
    assert "A" not in sim.view
    # Deleted by ATDIST within 1 NM of (0.1, 0): 11.1 km - 1.852 km flown north.
    rec = sim.flight_log[0]
    assert rec.distance_m == pytest.approx(0.1 * math.pi / 180 * 6371000 - 1 * NM, abs=60)


def test_schedule_delay_pcall_rel_abs(tmp_path):
    sub = tmp_path / "sub.scn"
    sub.write_text("00:00:05.00>CRE %0 EC35 0 0 0 1000 %1\n")
    main = tmp_path / "main.scn"
    main.write_text(
        "00:00:10.00>PCALL sub.scn REL R1 100\n"
        "00:00:10.00>PCALL sub.scn ABS R2 90\n"
        "00:00:00.00>SCHEDULE 00:00:20 CRE S EC35 1 1 0 1000 100\n"
        "00:00:10.00>DELAY 5 CRE D EC35 2 2 0 1000 100\n"
    )
    sim = Simulation(use_bluesky_navdata=False)
    created = {}
    sim.hooks.created.add(lambda s, i: created.setdefault(s.view.ids[i], s.simt))
    sim.load_scenario(main)
    sim.run_until(30.0)
    assert created == {"R2": 10.0, "R1": 15.0, "D": 15.0, "S": 20.0}
    assert sim.view.cas[sim.view.slot("R1")] == pytest.approx(100 * KTS)


def test_dt_hold_op_reset_ic(tmp_path, sim):
    sim.stack("DT 0.1")
    assert sim.dt == 0.1
    assert not sim.stack("DT 0")
    sim.stack("CRE A EC35 0 0 0 1000 100")
    sim.stack("HOLD")
    sim.run_until(10.0)
    assert sim.simt == 0.0
    sim.stack("OP")
    sim.run_until(10.0)
    assert sim.simt == pytest.approx(10.0)
    sim.stack("RESET")
    assert sim.simt == 0.0 and sim.view.n == 0
    scn = tmp_path / "x.scn"
    scn.write_text("00:00:01.00>CRE B EC35 0 0 0 1000 100\n")
    sim.stack(f"IC {scn}")
    sim.run_until(2.0)
    assert sim.view.ids == ("B",) and sim.scenario_name == "x"


def test_asas_settings_are_stored(sim):
    sim.stack("ASAS ON; ZONER 0.243; ZONEDH 500; DTLOOK 60; RESO MVP")
    s = sim.settings
    assert s.cd_method == "STATEBASED" and s.zoner_m == pytest.approx(450.0, abs=0.1)
    assert s.zonedh_m == pytest.approx(152.4) and s.dtlook_s == 60.0 and s.reso == "MVP"
    assert not sim.stack("ASAS MAYBE")


def test_display_commands_are_ignored_with_one_note(sim):
    sim.load_text("00:00:00.00>PAN EHAM\n00:00:00.00>PAN 52 4\n00:00:00.00>ZOOM 2\n00:00:00.00>SWRAD SAT\n")
    sim.run_until(1.0)
    notes = [m for m in sim.reporter.messages if m.kind == "note"]
    assert len(notes) == 3 and not errors_of(sim)


def test_console_zoom_keys_of_any_length_are_zoom(sim):
    # BlueSky's corpus has lines of 8 and 14 plus signs (Malik/nycGrid_test.scn, taxiwpts.scn).
    sim.load_text("00:00:00.00>++++++++++++++\n00:00:00.00>--\n00:00:00.00>=+-\n00:00:00.00>-5\n")
    sim.run_until(1.0)
    assert [m.text for m in sim.reporter.messages if m.kind == "note"] == [
        "ZOOM ignored: aamsim is headless (display or real-time command)"]
    assert len(errors_of(sim)) == 1 and "unknown command -5" in errors_of(sim)[0]  # a number is no zoom key


def test_unknown_command_and_bad_arguments_report_and_continue(sim):
    sim.load_text(
        "00:00:00.00>CRE A EC35 0 0 0 1000 100\n"
        "00:00:01.00>ALT A FLXX\n"
        "00:00:01.00>HDG B 90\n"
        "00:00:01.00>SPD A 100 200\n"
        "00:00:02.00>ECHO done\n"
    )
    sim.run_until(3.0)
    errs = errors_of(sim)
    assert len(errs) == 3
    assert errs[0].startswith("<scenario>:2:") and "FLXX" in errs[0]
    assert "no aircraft with callsign B" in errs[1]
    assert "extra argument" in errs[2] and '"200"' in errs[2]


def test_help_and_pos(sim):
    assert sim.stack("HELP ALT")
    assert "ALT acid" in sim.reporter.messages[-1].text
    sim.stack("CRE A EC35 0 0 0 1000 100")
    sim.stack("POS A")
    assert "A EC35" in sim.reporter.messages[-1].text
    sim.stack("A")  # a bare callsign is a POS query
    assert sim.reporter.messages[-1].text.startswith("A EC35")


def test_autodelete_and_arrival(sim):
    sim.load_text("00:00:00.00>AUTODELETE ON\n00:00:00.00>CRE A EC35 0 0 0 1000 100\n"
                  "00:00:00.00>DEST A 0.05 0\n00:00:00.00>VNAV A OFF\n")
    sim.run_until(200.0)
    assert sim.view.n == 0
    rec = sim.flight_log[0]
    assert rec.arrived and rec.destination == "0.050000,0.000000"
    # 0.05 deg of latitude is 5559.7 m on the 6371 km sphere; TAS at 1000 ft for 100 kt CAS.
    tas = float(cas2tas(100 * KTS, 1000 * FT))
    assert rec.deleted_s == pytest.approx(5559.7 / tas, abs=0.1)


def test_plugins_list_and_load_example(sim):
    sim.stack("PLUGINS LIST")
    assert "EXAMPLE" in sim.reporter.messages[-1].text
    sim.stack("PLUGINS LOAD EXAMPLE")
    sim.stack("CRE A EC35 0 0 0 1000 100")
    sim.run_until(5.0)
    sim.stack("COUNTSTEPS")
    # samples at t = 0, 1, ..., 5 s
    assert sim.reporter.messages[-1].text.startswith("6 samples, 6 aircraft-samples")
    assert not sim.stack("PLUGIN LOAD NOSUCH")
