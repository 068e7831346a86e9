"""What one client of ``aamsim serve`` may make the server do (issue 26, items 5 and 8).

``stack "REPLAY OPENSKY,,..."`` made the server poll the network, paced to wall time, and every other
client waited; one ``stack`` of 3,000 ``CRE`` at one spot made the next step take 53 s and 4.5 GB; ``open``
told files outside the roots from missing ones; the strategic planner's probe opened PCALLed files outside
the roots.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bridge_util import REPLY_TIMEOUT_MS, raw_socket, thread_server, write_scenario

from aamsim import Simulation
from aamsim.conflicts import service as conflict_service
from aamsim.errors import CommandError
from aamsim.limits import SimulationLimits
from aamsim.realtraffic.replay import replays_of
from rlbridge.protocol import decode, request
from rlbridge.scenario_access import ScenarioRoots
from rlbridge.usecases.reservation import probe_intents
from rlbridge.usecases.schedule import split_schedule


@pytest.fixture
def root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "root"
    folder.mkdir()
    write_scenario(folder)
    monkeypatch.chdir(folder)
    return folder


def ask(sock, op: str, **fields):  # type: ignore[no-untyped-def]
    sock.send_multipart(request(op, 1, **fields))
    return decode(sock.recv_multipart())


def test_a_client_cannot_start_live_polling_unless_the_server_allows_it(root: Path) -> None:
    with thread_server() as server, raw_socket(server.endpoint, timeout_ms=REPLY_TIMEOUT_MS) as sock:
        assert ask(sock, "reset", scenario="conflicts.scn", seed=1)["ok"]
        messages = ask(sock, "stack", text="REPLAY OPENSKY,,47.2,8.3,47.6,8.8")["messages"]
        assert any("live OpenSky overlays are not allowed in this simulation" in m and "--allow-live-overlays" in m
                   for m in messages), messages
        sim = next(iter(server.sessions.values())).core.sim
        assert sim is not None and replays_of(sim) == []
        # RESET (which restores the settings) does not lift it.
        ask(sock, "stack", text="RESET")
        messages = ask(sock, "stack", text="REPLAY OPENSKY,,47.2,8.3,47.6,8.8")["messages"]
        assert any("not allowed" in m for m in messages), messages
        refused = ask(sock, "reset", scenario="conflicts.scn", seed=1, params={"overlay": "opensky:47.2,8.3,47.6,8.8"})
        assert refused["ok"] is False and "live OpenSky overlays are not allowed" in refused["error"]
        assert ask(sock, "hello")["ok"]


def test_the_server_option_lets_live_overlays_through_to_the_simulation() -> None:
    from aamsim.realtraffic.overlay import start_overlay
    from rlbridge.server import ServerOptions

    assert ServerOptions(allow_live_overlays=True).session_limits().live_data is True
    sim = Simulation(use_bluesky_navdata=False)
    sim.limits = ServerOptions().session_limits()
    with pytest.raises(CommandError, match="not allowed"):
        start_overlay(sim, "opensky:47.2,8.3,47.6,8.8")


def test_a_session_flies_at_most_max_aircraft(root: Path) -> None:
    with thread_server(max_aircraft=40) as server, raw_socket(server.endpoint, timeout_ms=REPLY_TIMEOUT_MS) as sock:
        assert ask(sock, "reset", scenario="conflicts.scn", seed=1)["ok"]
        sim = next(iter(server.sessions.values())).core.sim
        before = sim.view.n
        text = "; ".join(f"CRE Z{k} EC35 40.7 -74.0 0 500 0" for k in range(60))
        messages = ask(sock, "stack", text=text)["messages"]
        assert sim.view.n == 40
        refused = [m for m in messages if "flies at most 40 aircraft at once" in m]
        assert len(refused) == 60 - (40 - before) and "--max-aircraft" in refused[0]


def test_an_mcre_past_the_limit_is_refused_whole() -> None:
    sim = Simulation(use_bluesky_navdata=False)
    sim.limits = SimulationLimits(max_aircraft=25, why="a limit of this server")
    sim.stack("MCRE 100")
    assert sim.view.n == 0  # none created: it used to create 25 of the 100 and stop
    assert sim.reporter.errors()[-1].text.endswith("at most 25 aircraft at once, and 0 fly at t = 0.00 s: 25 more fit; "
                                                   "none created; a limit of this server")
    sim.stack("MCRE 25")
    assert sim.view.n == 25


def test_a_conflict_check_stops_at_the_pair_bound_with_one_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(conflict_service, "MAX_PAIRS_PER_CHECK", 100)
    monkeypatch.setattr(conflict_service, "PAIRS_PER_AIRCRAFT", 1)  # 30 aircraft: the bound is the 100
    sim = Simulation(use_bluesky_navdata=False)
    sim.services.start()
    sim.stack("ASAS ON")
    for k in range(30):  # 435 pairs, all in conflict and inside both volumes
        sim.stack(f"CRE Z{k} EC35 40.7 -74.0 {k * 12} 500 10")
    sim.run_until(5.0)
    service = sim.services.start().conflicts
    assert service.checks_cut >= 4
    errors = [m.text for m in sim.reporter.errors()]
    assert len(errors) == 1 and "over 100 aircraft pairs close together" in errors[0]
    assert service.state is not None and len(service.state.pi) <= 100 + 30
    assert all(log.n <= 100 + 30 for log in service.logs.values())


def test_a_pile_of_aircraft_on_one_spot_costs_a_bounded_check() -> None:
    """1,000 aircraft on one spot: 499,500 pairs in conflict; a check handles 100,000 and stops."""
    sim = Simulation(use_bluesky_navdata=False)
    sim.services.start()
    sim.stack("ASAS ON")
    sim.stack("; ".join(f"CRE Z{k} EC35 40.7 -74.0 0 500 0" for k in range(1000)))
    sim.run_until(2.0)
    service = sim.services.start().conflicts
    cap = conflict_service.MAX_PAIRS_PER_CHECK
    assert service.checks_cut >= 2 and service.state is not None
    assert cap <= len(service.state.pi) <= cap + 1000 and len(service.state.los_pi) <= cap + 1000
    assert all(cap <= log.n <= cap + 1000 for log in service.logs.values())
    pi, _, _ = conflict_service.pairs_within(sim, 1000.0)
    assert cap <= len(pi) <= cap + 1000


def _grid_of_aircraft(side: int, spacing_m: float) -> str:
    """``side`` x ``side`` EC135s at 500 ft, ``spacing_m`` apart, all flying north at 60 kt: every aircraft has
    its neighbours within a few hundred metres, and none of them changes for the seconds a test flies."""
    lines = []
    for i in range(side):
        for j in range(side):
            lat, lon = 40.7 + i * spacing_m / 111195.0, -74.0 + j * spacing_m / (111195.0 * 0.7581)
            lines.append(f"CRE G{i}_{j} EC35 {lat:.7f} {lon:.7f} 0 500 60")
    return "; ".join(lines)


def _events_on_the_grid(side: int) -> tuple[int, int, int]:
    sim = Simulation(use_bluesky_navdata=False)
    sim.services.start()
    sim.stack(_grid_of_aircraft(side, 400.0))
    sim.run_until(3.0)
    service = sim.services.start().conflicts
    return service.checks_cut, service.count("lowc"), len(sim.reporter.errors())


def test_the_pair_bound_grows_with_the_traffic(monkeypatch: pytest.MonkeyPatch) -> None:
    """The bound is per aircraft beyond its floor, so dense but spread traffic (here 400 aircraft 400 m apart:
    3,570 pairs within the 1 km search, 760 of them within the 450 m of LoWC) is never cut, while a flat bound
    would lose its events; one spot still costs a bounded check (the test above)."""
    assert conflict_service.pair_bound(10) == conflict_service.MAX_PAIRS_PER_CHECK
    assert conflict_service.pair_bound(20_000) == 20_000 * conflict_service.PAIRS_PER_AIRCRAFT
    cut, lowc_all, errors = _events_on_the_grid(20)
    assert (cut, errors, lowc_all) == (0, 0, 2 * 20 * 19)  # each pair of neighbours in a row or a column
    monkeypatch.setattr(conflict_service, "MAX_PAIRS_PER_CHECK", 500)
    monkeypatch.setattr(conflict_service, "PAIRS_PER_AIRCRAFT", 50)  # 20,000 for 400 aircraft
    assert _events_on_the_grid(20) == (0, lowc_all, 0)
    monkeypatch.setattr(conflict_service, "PAIRS_PER_AIRCRAFT", 0)  # a flat 500: cut, events lost
    cut, lowc, errors = _events_on_the_grid(20)
    assert cut > 0 and lowc < lowc_all and errors == 1


def test_normal_traffic_never_meets_the_pair_bound() -> None:
    sim = Simulation(use_bluesky_navdata=False, seed=3)
    sim.services.start()
    sim.stack("ASAS ON; MCRE 400")
    sim.run_until(30.0)
    assert sim.services.start().conflicts.checks_cut == 0 and sim.reporter.errors() == []


def test_involved_since_by_hand() -> None:
    """The vectorised query gives each aircraft its smallest distance over events open since t0."""
    from aamsim.conflicts.events import EventLog

    log = EventLog("lowc")
    ids = ["A", "B", "C"]
    serial = np.array([0, 1, 2])
    rank = np.array([0, 1, 2])
    cpa = np.zeros((3, 12))
    # At t = 10: A-B at 300 m (stays inside), B-C at 200 m (left 1 s ago), A-C at 400 m (stays inside).
    log.update(10.0, 9.0, ids, np.array([0, 1, 0]), np.array([1, 2, 2]), serial, rank, np.zeros(3),
               np.array([0.0, -1.0, 0.0]), np.array([300.0, 200.0, 400.0]), np.zeros(3), cpa, None)
    assert log.involved_since(8.5) == {"A": 300.0, "B": 200.0, "C": 200.0}
    assert log.involved_since(9.5) == {"A": 300.0, "B": 300.0, "C": 400.0}  # B-C ended at 9 s


def test_open_answers_a_file_outside_the_roots_as_a_missing_one(root: Path, tmp_path: Path) -> None:
    outside = tmp_path / "exists.scn"
    outside.write_text("00:00:00.00>ECHO secret\n")
    with thread_server() as server, raw_socket(server.endpoint, timeout_ms=REPLY_TIMEOUT_MS) as sock:
        there = ask(sock, "open", scenario=str(outside))
        missing = ask(sock, "open", scenario=str(tmp_path / "missing.scn"))
        assert (there["code"], missing["code"]) == ("not_found", "not_found")
        assert there["error"].replace("exists.scn", "X") == missing["error"].replace("missing.scn", "X")
        assert ask(sock, "reset", scenario="conflicts.scn", seed=1)["ok"]
        for verb in ("PCALL", "IC"):
            a = ask(sock, "stack", text=f"{verb} {outside}")["messages"]
            b = ask(sock, "stack", text=f"{verb} {tmp_path / 'missing.scn'}")["messages"]
            assert [m.replace("exists.scn", "X") for m in a] == [m.replace("missing.scn", "X") for m in b], (a, b)
            assert a and "not found" in a[0] and "secret" not in " ".join(a)


def test_the_planners_probe_obeys_the_sessions_scenario_roots(tmp_path: Path) -> None:
    root = tmp_path / "root"
    root.mkdir()
    outside = tmp_path / "outside.scn"
    outside.write_text("00:00:00.00>CRE X9 EC35 40.7 -74.0 0 500 100\n")
    scn = root / "s.scn"
    scn.write_text(f"00:00:00.00>PCALL {outside}\n00:00:00.00>CRE A1 EC35 40.7 -74.1 90 500 100\n"
                   "00:00:00.00>ADDWPT A1 40.7 -74.05\n00:00:00.00>A1 ATDIST 40.7 -74.05 0.05 DEL A1\n")
    seen: list[Path] = []
    roots = ScenarioRoots([root])

    def guard(path: Path) -> None:
        seen.append(path)
        roots.guard(path)

    sim = Simulation(use_bluesky_navdata=False)
    sim.files.guard = guard
    sim.files.search_path.insert(0, root)
    parsed = sim.parse(scn.read_text(), str(scn))
    schedule = split_schedule(list(parsed.commands), sim.commands.__contains__)
    probe_intents(sim, schedule, 1.0, 600.0)
    assert [p.resolve() for p in seen] == [outside.resolve()]  # asked, and refused
