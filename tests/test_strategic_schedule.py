"""Departure requests from scenario commands (rlbridge/usecases/schedule.py)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.scenarios import resolve_scenario
from rlbridge.usecases.schedule import split_schedule


def _split(text: str):
    sim = Simulation()
    parsed = sim.parse(text, "t.scn")
    return parsed.commands, split_schedule(parsed.commands, sim.commands.__contains__)


def test_blocks_from_cre_schedule_delay_and_acid_first_form():
    cmds, s = _split(
        "00:00:00.00>DEFWPT VP1 0 0\n"
        "00:00:10.00>CRE A EC35 0 0 0 500 0\n"
        "00:00:10.00>DEST A VP1\n"
        "00:00:10.00>A ATDIST 0 0 0.05 DEL A\n"
        "00:00:00.00>SCHEDULE 00:01:00 CRE B EC35 0 0 0 500 0\n"
        "00:00:00.00>SCHEDULE 00:01:00 SPD B 80\n"
        "00:00:30.00>DELAY 00:00:10 CRE C EC35 0 0 0 500 0\n"
        "00:00:45.00>SPD C 60\n"
        "00:00:05.00>SPD A 50\n"  # before A exists: not A's (the simulation reports it)
        "00:00:20.00>MCRE 2\n"
    )
    assert [(r.key, r.request_s) for r in s.requests] == [("A", 10.0), ("C", 40.0), ("B", 60.0)]
    a, c, b = s.requests
    assert [str(x.command) for x in a.commands] == ["CRE A EC35 0 0 0 500 0", "DEST A VP1",
                                                    "ATDIST A 0 0 0.05 DEL A"]
    assert [(x.time_s, str(x.command)) for x in b.commands] == [(60.0, "CRE B EC35 0 0 0 500 0"), (60.0, "SPD B 80")]
    assert [(x.time_s, str(x.command)) for x in c.commands] == [(40.0, "CRE C EC35 0 0 0 500 0"), (45.0, "SPD C 60")]
    assert [str(x.command) for x in s.other] == ["DEFWPT VP1 0 0", "SPD A 50", "MCRE 2"]
    # Nothing lost, nothing invented: every command is in one place exactly once.
    n_blocks = sum(len(r.commands) for r in s.requests)
    assert n_blocks + len(s.other) == len(cmds)
    first = a.shifted(120.0)[0]
    assert (first.time_s, str(first.command)) == (130.0, "CRE A EC35 0 0 0 500 0")


def test_a_callsign_created_twice_is_two_requests():
    _, s = _split("00:00:00.00>CRE A EC35 0 0 0 500 0\n00:00:50.00>DEL A\n"
                  "00:01:00.00>CRE A EC35 1 1 0 500 0\n00:01:00.00>SPD A 40\n")
    assert [(r.key, r.acid, len(r.commands)) for r in s.requests] == [("A", "A", 2), ("A#2", "A", 2)]


def test_the_shipped_new_york_schedule_has_one_block_per_flight():
    path = resolve_scenario("nyc_train_100.scn")
    _, s = _split(path.read_text())
    assert len(s.requests) == 100
    assert all(len(r.commands) >= 7 and r.commands[0].command.name == "CRE" for r in s.requests)
    assert {c.command.name for c in s.other} == {"DEFWPT"}
    assert [r.request_s for r in s.requests] == sorted(r.request_s for r in s.requests)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 600), st.sampled_from(["A", "B", "C"]),
                          st.sampled_from(["CRE {} EC35 0 0 0 500 0", "SPD {} 50", "DEL {}", "ECHO hi {}",
                                           "SCHEDULE 00:05:00 CRE {} EC35 0 0 0 500 0",
                                           "DELAY 30 SPD {} 20"])), max_size=25))
def test_every_command_lands_in_exactly_one_place(lines):
    text = "".join(f"00:{t // 60:02d}:{t % 60:02d}.00>{cmd.format(ac)}\n" for t, ac, cmd in lines)
    cmds, s = _split(text)
    placed = [c for r in s.requests for c in r.commands]
    assert len(placed) + len(s.other) == len(cmds)
    for r in s.requests:
        assert r.commands[0].command.name in ("CRE", "CREATE") and r.commands[0].time_s == r.request_s
        assert all(c.time_s >= r.request_s for c in r.commands)
