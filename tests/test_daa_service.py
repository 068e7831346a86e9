"""The detect-and-avoid service (RESO DAA, the DAA command) and the daa baseline policy, end to end."""

from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from aamsim import Simulation
from aamsim.units import KTS

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data"
ENCOUNTERS = DATA / "daa_encounters.scn"
WINDOW = DATA / "nyc_train_daa_window.scn"  # 12 flights of nyc_train_100
TURNS = DATA / "daa_turns.scn"  # a head-on pair, a crossing and an overtake that need heading advisories
ENV = dict(os.environ, PYTHONPATH=str(ROOT))


def run_cli(args: list[str], cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], cwd=cwd, env=ENV, capture_output=True, text=True,
                          timeout=timeout, check=False)


def test_aamsim_run_with_reso_daa_has_fewer_losses_of_well_clear(tmp_path):
    on = tmp_path / "daa_on.scn"
    on.write_text("00:00:00.00>RESO DAA\n" + ENCOUNTERS.read_text())
    summaries = {}
    for name, scn in (("off", ENCOUNTERS), ("on", on)):
        proc = run_cli(["-m", "aamsim", "run", str(scn), "--until", "300", "--out", name, "--quiet"], tmp_path)
        assert proc.returncode == 0, proc.stderr
        summaries[name] = json.loads((tmp_path / name / "summary.json").read_text())
    off, daa = summaries["off"], summaries["on"]
    # Unequipped: the overtake, the crossing and the merge each lose well clear (two are NMACs).
    assert off["safety"]["lowc_events"] == 3 and off["safety"]["nmac_events"] == 2
    assert "daa" not in off and off["operational"]["advisories"] == 0
    # With the speed-band resolutions none does, and the advisories are counted.
    assert daa["safety"]["lowc_events"] == 0 and daa["safety"]["min_separation_m"] > 450
    assert daa["daa"]["advisories_issued"] == daa["operational"]["advisories"] > 0
    assert daa["daa"]["alerts"]["corrective"] + daa["daa"]["alerts"]["warning"] >= 3


def test_reso_daa_brings_aircraft_turned_near_their_destination_to_it(tmp_path):
    """Run as a user would. Before the service kept its aircraft's routes, UAM0947 and UAM0950 were turned
    near their destination, passed it outside uam2scn's 0.05 NM ATDIST radius and flew on: 10 of 12 arrived."""
    proc = run_cli(["-m", "aamsim", "run", str(WINDOW), "--seed", "1", "--set", "stack=RESO DAA", "--out", "daa",
                    "--quiet"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "daa" / "summary.json").read_text())
    assert summary["flights_created"] == summary["flights_arrived"] == 12
    assert summary["daa"]["advisories_by_axis"]["heading"] > 0


def window_with_daa() -> tuple[Simulation, set[str]]:
    """The window under RESO DAA, and a set that collects every aircraft the service's route keeper follows."""
    sim = Simulation(seed=1)
    sim.load_scenario(WINDOW)
    sim.stack("RESO DAA")
    followed: set[str] = set()
    sim.hooks.post_step.add(lambda s: followed.update(s.services.daa.keeper.steered), interval_s=1.0, name="test")
    return sim, followed


def test_the_route_keeper_follows_the_aircraft_advised_off_their_route_until_they_arrive():
    sim, followed = window_with_daa()
    sim.run(until_s=1500.0)
    keeper = sim.services.daa.keeper
    assert {"UAM0947", "UAM0950"} <= followed  # the two that flew away before
    assert keeper.steered == {} and keeper.rejoining == set()  # every one arrived and was removed: forgotten
    flights = list(sim.flights())
    assert len(flights) == 12 and all(f.arrived for f in flights)


def test_aircraft_released_by_reso_off_still_go_back_to_their_destination():
    """RESO OFF at 458 s releases UAM0947 277 m from its destination, inside its turn circle: it flies straight
    on (waiting to rejoin) while the service is off, and is still brought back (it flew on for good when the
    keeper ran only while RESO DAA was on)."""
    sim, _ = window_with_daa()
    sim.run(until_s=458.0)
    assert "UAM0947" in sim.services.daa.advisories
    sim.stack("RESO OFF")
    sim.run(until_s=459.5)
    assert sim.services.daa.advisories == {} and sim.services.daa.keeper.rejoining == {"UAM0947"}
    sim.run(until_s=1500.0)
    assert all(f.arrived for f in sim.flights())


def test_a_reset_forgets_the_followed_aircraft():
    sim, _ = window_with_daa()
    sim.run(until_s=460.0)
    assert sim.services.daa.keeper.steered
    sim.reset()
    assert sim.services.daa.keeper.steered == {} and sim.services.daa.keeper.rejoining == set()


def crossing_sim(reso: str, axes: str = "") -> Simulation:
    sim = Simulation(seed=0)
    sim.services.start()
    sim.stack("CRE C1 EC35 40.700000 -74.100000 0 1000 100")
    sim.stack("CRE C2 EC35 40.720000 -74.085000 270 1000 60")
    sim.stack(f"RESO {reso}")
    if axes:
        sim.stack(f"DAA RESOAXES {axes}")
    return sim


def test_advisory_is_held_until_clear_then_the_own_speed_resumes():
    sim = crossing_sim("DAA", "GS")  # speed-only resolutions
    service = sim.services.daa
    sim.run_until(3.0)
    advised = set(service.advisories)
    assert advised  # the crossing is alerted at once (a warning: 5 s to loss of well clear)
    acid = next(iter(advised))
    adv = service.advisories[acid]
    slot = sim.view.slot(acid)
    assert sim.view.selspd[slot] == pytest.approx(adv.cas_mps)  # flying the advised speed
    # The advised ground speed is conflict-free for the look-ahead: outside every band.
    bands = service.daa.gs_bands(sim, np.array([slot]))
    assert not bands.conflicts(slot, adv.gs_mps)
    sim.run_until(120.0)  # well past the crossing
    assert service.advisories == {}
    own = {"C1": 100 * KTS, "C2": 60 * KTS}
    for a, cas in own.items():
        assert sim.view.selspd[sim.view.slot(a)] == pytest.approx(cas)  # resumed
    assert sim.services.conflicts.count("lowc") == 0


def test_reso_off_releases_the_advisories_and_other_methods_are_stored_only():
    sim = crossing_sim("DAA")
    sim.run_until(3.0)
    assert sim.services.daa.advisories
    sim.stack("RESO OFF")
    sim.run_until(5.0)
    assert sim.services.daa.advisories == {}
    assert sim.view.selspd[sim.view.slot("C1")] == pytest.approx(100 * KTS)
    unequipped = crossing_sim("MVP")  # stored, noted; no resolution
    unequipped.run_until(60.0)
    assert unequipped.services.daa.issued == 0 and unequipped.services.conflicts.count("lowc") == 1


def test_daa_command_sets_lists_and_rejects():
    sim = Simulation(seed=0)
    sim.services.start()
    params = sim.services.daa.daa.params
    assert (params.dmod_m, params.hmd_m, params.taumod_s) == (450.0, 450.0, 35.0)
    sim.stack("DAA DMOD 600; DAA TAUMOD 20; DAA LEVEL 3; DAA SPDMAX 120")
    params = sim.services.daa.daa.params
    assert (params.dmod_m, params.taumod_s, params.resolve_level, params.speed_max_kts) == (600.0, 20.0, 3, 120.0)
    sim.stack("DAA HYSTERESIS 2")
    assert sim.services.daa.daa.params.hysteresis_s == 2.0
    params = sim.services.daa.daa.params
    for line in ("DAA FOO 1", "DAA DMOD -5", "DAA LEVEL 7", "DAA SPDMIN 200", "DAA HDGSTEP 0", "DAA HYSTERESIS -1"):
        assert not sim.stack(line), line
    # Rejected settings leave the parameters as they were; the errors say why.
    assert sim.services.daa.daa.params == params
    errors = [m.text for m in sim.reporter.errors()]
    assert len(errors) == 6
    assert "unknown DAA setting FOO; known: DMOD, HMD, TAUMOD, ZTHR, TCOA" in errors[0]
    assert "dmod_m must be a finite number >= 0" in errors[1]
    assert "resolve_level must be 1" in errors[2] and "speed_min_kts is above speed_max_kts" in errors[3]
    # A zero heading step divided by zero inside the heading bands at the first advisory, ending the run.
    assert "hdg_step_deg must be positive, not 0.0" in errors[4]
    assert "hysteresis_s must be a finite number >= 0" in errors[5]
    # A thinner well-clear volume changes what is alerted.
    crossing = crossing_sim("DAA")
    crossing.stack("DAA TAUMOD 0")
    crossing.run_until(1.0)
    t0 = crossing.services.daa.daa.alerts(crossing).time_to_lowc_s
    assert np.all(t0 > 30.0)  # only the DMOD circle: entered about 34.7 s from the start


def test_aamsim_commands_documents_reso_daa_and_the_settings(tmp_path):
    proc = run_cli(["-m", "aamsim", "commands", "--group", "conflicts"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    reso = next(k for k, line in enumerate(lines) if line.startswith("RESO"))
    assert "DAA" in lines[reso + 1]
    daa = next(k for k, line in enumerate(lines) if line.startswith("DAA"))
    assert "detect-and-avoid threshold" in lines[daa + 1]


# ---------------------------------------------------------------------------- the baseline policy
def test_aamgym_evaluate_baseline_daa_on_a_small_scenario(tmp_path):
    proc = run_cli(["-m", "rlbridge.experiment", "evaluate", "baseline=daa", f"scenario={DATA / 'tiny_conflict.scn'}",
                    "episodes=2", "workers=0", "env.time_limit_s=600", "hydra.run.dir=eval"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    ev = json.loads((tmp_path / "eval" / "evaluation.json").read_text())
    assert set(ev["policies"]) == {"daa", "unequipped", "mvp_speed"} and ev["algorithm"] == "daa"
    daa, unequipped = ev["policies"]["daa"], ev["policies"]["unequipped"]
    assert not daa["learned"] and daa["label"].startswith("DAA")
    # tiny_conflict: unequipped, the pair collides at the merge; DAA sequences them, both arrive.
    assert unequipped["nmac_events"]["mean"] == 1.0
    assert daa["nmac_events"]["mean"] == 0.0 and daa["lowc_events"]["mean"] == 0.0
    assert daa["operational"]["flights_completed"]["mean"] == 2.0
    assert daa["operational"]["alert_rate_per_flight_hour"]["mean"] > 0
    assert daa["risk_ratio"]["mean"] == 0.0


def test_aamgym_evaluate_unknown_baseline_lists_the_known_ones(tmp_path):
    proc = run_cli(["-m", "rlbridge.experiment", "evaluate", "baseline=acas_sxu",
                    f"scenario={DATA / 'tiny_conflict.scn'}", "episodes=1", "workers=0", "hydra.run.dir=eval"],
                   tmp_path, timeout=120)
    # Refused before the job starts (the preflight): one line naming the key, exit status 2.
    assert proc.returncode == 2
    assert "baseline=acas_sxu: unknown baseline; known: unequipped, mvp_speed, daa, mvp" in proc.stderr
    proc = run_cli(["-m", "rlbridge.experiment", "evaluate", "episodes=1", "hydra.run.dir=eval"], tmp_path,
                   timeout=120)
    assert proc.returncode != 0
    # The configuration check before Hydra starts names the three ways to say what is evaluated.
    assert "run=RUN_DIR" in proc.stderr and "policy=pretrained:NAME" in proc.stderr and "baseline=NAME" in proc.stderr


def test_daa_policy_acts_on_any_use_case_with_speed_actions():
    from rlbridge.agents import make_actor
    from rlbridge.agents.rollout import EnvSpec, policy_input

    core = EnvSpec(str(DATA / "tiny_conflict.scn"), "reach_destination", {}, 300.0).make(None)
    actor = make_actor({"kind": "daa", "config": {"daa": {"taumod_s": 20.0}}})
    actor.check_usecase(core.usecase)
    assert actor.daa.params.taumod_s == 20.0
    core.publish_targets = True  # what a rollout asks for an actor that reads the action targets
    result = core.reset(0)
    rng = np.random.default_rng(0)
    advised = 0
    while not result.done:
        out = actor.act(result, policy_input(actor, core), rng, {})
        acts = {a: int(x) for a, x, g in zip(result.agents, out.actions, out.advise) if g}
        assert all(0 <= x < 3 for x in acts.values())  # reach_destination's three speeds
        advised += len(acts)
        result = core.step(acts)
    assert advised > 0
    assert core.metrics(("safety",))["safety"]["nmac_events"] == 0


def test_daa_policy_releases_an_agent_its_actions_cannot_bring_closer_to_its_own_speed(tmp_path):
    # Regression (nyc_train_100: aircraft held hovering for minutes): RA1 is ready to resume but no action
    # brings it closer to its own speed (the corridor's actions move 35 m/s per decision); kept "ready" it
    # deferred every nearby aircraft with a later callsign (resume_order) for as long as it flew, here RB2,
    # which can resume. Released with the hold action instead; RB2, 2 km beside it, is not held up.
    from rlbridge.agents import make_actor
    from rlbridge.agents.daa import _Held
    from rlbridge.agents.rollout import policy_input
    from rlbridge.core import EpisodeCore

    scn = tmp_path / "parallel.scn"
    scn.write_text("00:00:00.00>CRE RA1 EC35 40.700000 -74.000000 90 1000 100\n"
                   "00:00:00.00>CRE RB2 EC35 40.718000 -74.000000 90 1000 40\n"  # 2 km apart, parallel
                   "00:00:00.00>ADDWPT RA1 40.700000 -73.700000\n00:00:00.00>ADDWPT RB2 40.718000 -73.700000\n")
    core = EpisodeCore(str(scn), "corridor_sa", {"alt_noise_ft": 0.0}, time_limit_s=300.0)
    actor = make_actor({"kind": "daa"})
    actor.check_usecase(core.usecase)
    rng = np.random.default_rng(0)
    core.publish_targets = True  # what a rollout asks for an actor that reads the action targets
    result = core.reset(0)
    out = actor.act(result, policy_input(actor, core), rng, {})
    assert not out.advise.any()  # parallel, 2 km apart: no alert
    view = core.sim.view
    cas = {a: float(view.cas[view.slot(a)]) for a in ("RA1", "RB2")}
    actor._held.update({"RA1": _Held(1, cas["RA1"] + 12.0), "RB2": _Held(1, cas["RB2"] + 34.0)})
    out = actor.act(result, policy_input(actor, core), rng, {})
    seen = {a: (int(x), bool(g)) for a, x, g in zip(result.agents, out.actions, out.advise)}
    assert seen["RA1"] == (1, True) and "RA1" not in actor._held  # holds the speed it has, released
    assert seen["RB2"] == (2, True)  # accelerates towards its own speed at once


def test_resume_order_defers_only_ready_aircraft_whose_resumed_paths_meet():
    # B1 hovers 1 km ahead of A1 on A1's line, C1 3 km to the side on a parallel line; all three ready.
    sim = Simulation(seed=0)
    sim.services.start()
    for line in ("CRE A1 EC35 40.700000 -74.000000 90 1000 60", "CRE B1 EC35 40.700000 -73.988150 90 1000 0",
                 "CRE C1 EC35 40.727000 -74.000000 90 1000 0"):
        sim.stack(line)
    sim.run_until(0.0)
    daa = sim.services.daa.daa
    slots = np.array([sim.view.slot(a) for a in ("B1", "A1", "C1")])
    # Resumed A1 at 60 m/s closes on B1 at 20 m/s (within 450 m in 28 s): A1, the first callsign, resumes
    # and B1 waits; C1 stays well clear of both and resumes too.
    resumed = np.array([[20.0, 0.0, 0.0], [60.0, 0.0, 0.0], [60.0, 0.0, 0.0]])
    assert daa.resume_order(sim, slots, resumed).tolist() == [False, True, True]
    # Default: as they fly now (A1 at 60 kt towards the hovering B1): the same.
    assert daa.resume_order(sim, slots).tolist() == [False, True, True]
    # B1 resuming away from A1 faster than A1: they never meet, both go.
    apart = np.array([[60.0, 0.0, 0.0], [20.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    assert daa.resume_order(sim, slots, apart).tolist() == [True, True, True]
    # B1 released already and turning back to 20 m/s east: A1, though first by callsign, waits now; an
    # aircraft turning back whose way does not meet A1's holds nothing up.
    ready, went = slots[1:2], slots[0:1]
    assert daa.resume_order(sim, ready, resumed[1:2], went, resumed[0:1]).tolist() == [False]
    assert daa.resume_order(sim, ready, resumed[1:2], went, apart[0:1]).tolist() == [True]
    assert daa.resume_order(sim, ready, resumed[1:2], slots[2:3], resumed[2:3]).tolist() == [True]


# ------------------------------------------------------------------ releasing an advisory
def advisory_spells(scenario: Path, *settings: str, until_s: float = 300.0) -> dict[str, list[tuple[float, float]]]:
    """Per aircraft, the (first, last) cycle of each stretch it held an advisory, sampled after every DAA cycle."""
    sim = Simulation(seed=1)
    sim.load_scenario(scenario)
    sim.stack("RESO DAA")
    for line in settings:
        sim.stack(line)
    spells: dict[str, list[tuple[float, float]]] = {}

    def sample(s: Simulation) -> None:
        for acid in s.services.daa.advisories:
            runs = spells.setdefault(acid, [])
            if runs and runs[-1][1] >= s.simt - 1.5:
                runs[-1] = (runs[-1][0], s.simt)
            else:
                runs.append((s.simt, s.simt))

    sim.hooks.post_step.add(sample, interval_s=1.0, priority=30, name="test.sample")  # after the DAA cycle (20)
    sim.run(until_s=until_s)
    return spells


def test_a_released_aircraft_turns_back_without_being_advised_again():
    """The release test checks every heading of the turn back, not only the route's. Checked on the route's
    heading alone, 18 of the window's 31 releases were followed by a new advisory at the next cycle (the
    aircraft turned back through the intruder's way): 32 advisories for 12 flights."""
    spells = advisory_spells(WINDOW, "DAA HYSTERESIS 0", until_s=800.0)
    assert spells, "the window has encounters"
    for acid, runs in spells.items():
        for (_, released), (again, _) in itertools.pairwise(runs):
            assert again - released > 5.0, (acid, runs)
    assert sum(len(runs) for runs in spells.values()) <= 15


def test_an_advisory_is_held_for_the_hysteresis_time_once_clear():
    """Each aircraft stays on its first advisory exactly ``HYSTERESIS`` seconds longer: until the first release
    nothing else differs, the aircraft flying the advised heading (O1 and H1 clear at 3 s and 4 s, C1 at 18 s)."""
    def first_releases(*settings: str) -> dict[str, float]:
        spells = advisory_spells(TURNS, *settings, until_s=60.0)
        return {acid: runs[0][1] + 1.0 for acid, runs in spells.items() if acid in ("O1", "H1", "C1")}

    assert first_releases() == first_releases("DAA HYSTERESIS 0") == {"O1": 3.0, "H1": 4.0, "C1": 18.0}
    assert first_releases("DAA HYSTERESIS 5") == {"O1": 8.0, "H1": 9.0, "C1": 23.0}  # DAIDALUS's DO-365B time
    assert first_releases("DAA HYSTERESIS 12") == {"O1": 15.0, "H1": 16.0, "C1": 30.0}


def test_an_aircraft_turning_back_goes_first():
    """With 5 s holds, the head-on pair of daa_turns.scn ended them a cycle apart: H2, checked against H1 in the
    middle of its turn, turned back into it and both were advised again (16 advisories where 6 do). An
    aircraft still turning back now counts as having gone first."""
    spells = advisory_spells(TURNS, "DAA HYSTERESIS 5", until_s=300.0)
    assert all(len(runs) == 1 for runs in spells.values()), spells
    assert sorted(spells) == ["C1", "C2", "H1", "H2", "O1", "O2"]
    assert spells["H2"][0][1] > spells["H1"][0][1] + 5.0  # H2 held its advisory until H1 had turned back
