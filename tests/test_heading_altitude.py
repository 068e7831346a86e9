"""heading_altitude_sa: tactical deconfliction by heading and altitude advisories (docs/usecases.md)."""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

import rlbridge
from aamsim.geo import qdrdist
from aamsim.units import FT, R_EARTH
from rlbridge.agents import make_actor
from rlbridge.agents.rollout import policy_input
from rlbridge.core import EpisodeCore
from rlbridge.usecases.protocol import AdvisoryKindError
from rlbridge.usecases.spec import CapabilityError
from rlbridge.usecases.targets import reads_action_targets

HERE = Path(__file__).parent
ROOT = HERE.parent
TINY = str(HERE / "data" / "tiny_conflict.scn")
NEAR = str(HERE / "data" / "near_destination.scn")
WINDOW = str(HERE / "data" / "nyc_eval_window.scn")
TEND, TEND2 = (40.75, -73.96443), (40.85, -73.96443)
UC = "heading_altitude_sa"


def engine(**params) -> EpisodeCore:
    return EpisodeCore(TINY, UC, {"alt_noise_ft": 0.0, **params}, time_limit_s=600.0)


def test_gymnasium_and_pettingzoo_checkers_pass():
    env = gymnasium.make("aamgym/HeadingAltitudeSA-v1", scenario=TINY, time_limit_s=300.0)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()
    assert "aamgym/HeadingAltitudeSA-v0" in gymnasium.registry  # fixed traffic
    penv = rlbridge.parallel_env(TINY, usecase=UC, time_limit_s=300.0, obs_format="dict")
    parallel_api_test(penv, num_cycles=30)
    penv.close()


def test_actions_turn_off_the_bearing_change_level_and_resume():
    core = engine()
    uc = core.usecase
    core.reset(0)
    sim = core.sim
    i = sim.view.slot("TA1")
    # TA1 flies east towards TMRG: the bearing to its active waypoint is 90 deg.
    trk = uc.action_targets(sim, np.array([i]), "heading")[0]
    alt = uc.action_targets(sim, np.array([i]), "altitude")[0]
    assert trk == pytest.approx(np.repeat([50.0, 70.0, 90.0, 110.0, 130.0], 3), abs=1e-6)
    assert alt == pytest.approx(np.tile([500.0, 1000.0, 1500.0], 5) * FT)
    assert uc.resume_action == 7 and uc.offsets(14) == (40.0, 500.0)
    uc.apply_actions(sim, {"TA1": 14})  # +40 deg, +500 ft
    assert not sim.view.lnav[i] and sim.view.ap_trk[i] == pytest.approx(130.0, abs=1e-6)
    assert sim.view.selalt[i] == pytest.approx(1500.0 * FT)
    assert sim.view.flight(i).advisories == 1
    uc.apply_actions(sim, {"TA1": 14})  # the same advisory again: not a new one
    assert sim.view.flight(i).advisories == 1
    uc.apply_actions(sim, {"TA1": uc.resume_action})  # back on the route and level
    assert sim.view.lnav[i] and sim.view.selalt[i] == pytest.approx(1000.0 * FT)
    assert sim.view.flight(i).advisories == 1  # resuming is no advisory
    with pytest.raises(ValueError, match="action 15 for TA1 is not in 0..14"):
        uc.apply_actions(sim, {"TA1": 15})


def test_reward_by_hand_at_creation():
    core = engine()
    uc = core.usecase
    core.reset(0)
    sim = core.sim
    agents = ["TA1", "TB2"]
    # At creation both sit on their route legs at their own altitude: no deviation cost.
    dx = R_EARTH * math.radians(0.014230) * math.cos(math.radians(0.5 * (40.75 + 40.73922)))
    dy = R_EARTH * math.radians(40.75 - 40.73922)
    d = math.hypot(dx, dy)  # 1.70 km, inside d_max (3 km)
    fb = uc.feedback(sim, agents, {"TA1": 14, "TB2": uc.resume_action}, sim.simt)
    p = uc.params
    base = -p.alpha + p.delta * d - p.omega
    assert fb.rewards == pytest.approx([base - p.psi, base], abs=2e-4)
    assert fb.info["xtrack_m"] == pytest.approx([0.0, 0.0], abs=1e-6)
    assert not fb.info["nmac"].any() and fb.info["dalt_m"] == pytest.approx([0.0, 0.0])
    # 1 km off the leg and 100 m above: 0.02 + 0.02 more.
    sim.displace(np.array([sim.view.slot("TA1")]), np.array([-1000.0]), np.array([0.0]), np.array([100.0]))
    fb2 = uc.feedback(sim, ["TA1"], {}, sim.simt)
    assert fb2.info["xtrack_m"][0] == pytest.approx(1000.0, abs=1.0)  # right of the eastbound leg
    assert fb2.info["dalt_m"][0] == pytest.approx(100.0)


def test_advisory_kinds_are_declared_and_the_others_refused():
    core = engine()
    core.reset(0)
    uc = core.usecase
    assert uc.spec.action_kinds == ("heading", "altitude")
    with pytest.raises(AdvisoryKindError, match=r"applying speed advisories needs speed advisories; use case "
                                                r"heading_altitude_sa does not declare them \(its advisory kinds: "
                                                r"heading, altitude\)"):
        uc.action_targets(core.sim, np.array([0]), "speed")
    core.step({})
    with pytest.raises(CapabilityError, match=r"baseline mvp_speed does not fit use case heading_altitude_sa: it "
                                              r"needs speed actions \(its action kinds: heading, altitude\)"):
        make_actor({"kind": "mvp_speed"}).check_usecase(core.usecase)
    corridor = EpisodeCore(TINY, "corridor_sa", {}, time_limit_s=300.0)
    with pytest.raises(CapabilityError, match=r"baseline mvp does not fit use case corridor_sa: it needs heading "
                                              r"or altitude actions \(its action kinds: speed\)"):
        make_actor({"kind": "mvp"}).check_usecase(corridor.usecase)


def run_episode(kind: str, seed: int = 0) -> dict:
    core = engine()
    actor = make_actor({"kind": kind})
    check = getattr(actor, "check_usecase", None)
    if check is not None:
        check(core.usecase)
    rng = np.random.default_rng(0)
    core.publish_targets = reads_action_targets(actor)  # as a rollout asks for the acting policy
    result = core.reset(seed)
    while not result.done:
        out = actor.act(result, policy_input(actor, core), rng, {})
        advise = np.ones(len(result.agents), bool) if out.advise is None else out.advise
        acts = {} if out.actions is None else {a: int(x) for a, x, g in zip(result.agents, out.actions, advise)
                                               if g and a in result.alive}
        result = core.step(acts)
    return core.metrics()


def test_daa_and_mvp_baselines_resolve_the_merge_by_turning():
    off, daa, mvp = run_episode("unequipped"), run_episode("daa"), run_episode("mvp")
    assert off["safety"]["nmac_events"] == 1
    assert daa["safety"]["nmac_events"] == 0 and daa["safety"]["lowc_events"] == 0
    assert daa[UC]["heading_advisories"] > 0 and daa["operational"]["alert_rate_per_flight_hour"] > 0
    assert daa["operational"]["flights_completed"] == 2
    assert mvp["safety"]["nmac_events"] == 0 and mvp[UC]["heading_advisories"] > 0


def test_episode_variation_from_the_reset_seed():
    alts = []
    for seed in (1, 2):
        core = EpisodeCore(TINY, UC, {}, time_limit_s=300.0)
        core.reset(seed)
        alts.append(np.array(core.sim.view.alt))
    assert not np.allclose(alts[0], alts[1])  # the paper's +-100 ft drawn per seed
    v0 = gymnasium.make("aamgym/HeadingAltitudeSA-v0", scenario=TINY, time_limit_s=300.0).unwrapped
    assert v0._multi.core.usecase.params.alt_noise_ft == 0.0 and not v0._draw_ego


def test_heading_and_altitude_advisories_fly_on_bluesky(tmp_path):
    out = tmp_path / "bluesky.json"
    proc = subprocess.run([sys.executable, str(HERE / "bluesky_manoeuvre.py"), TINY, str(out)], capture_output=True,
                          text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = json.loads(out.read_text())
    for r in rows[:3]:  # advised: BlueSky's TA1 flies the mirror's heading and selected altitude
        assert not r["bs_lnav"] and r["bs_aptrk"] == pytest.approx(r["mirror_ap_trk"], abs=1e-4)
        assert r["bs_selalt"] == pytest.approx(r["own_alt"] + 500 * FT)
    assert rows[2]["bs_alt"] > rows[0]["bs_alt"] > rows[0]["own_alt"]  # climbing
    for r in rows[3:]:  # resumed: on its route (LNAV) and back to its own altitude
        assert r["bs_lnav"] and r["bs_selalt"] == pytest.approx(r["own_alt"])
    assert rows[-1]["bs_alt"] < rows[3]["bs_alt"]


# ------------------------------------------------------------------ back to the route and the destination
def near_episode() -> EpisodeCore:
    core = EpisodeCore(NEAR, UC, {"alt_noise_ft": 0.0}, time_limit_s=600.0)
    core.reset(0)
    return core


def fly(core: EpisodeCore, plan: dict[float, dict[str, int]], until_s: float = math.inf) -> None:
    """Step the episode (decisions every 10 s), giving the actions ``plan`` lists at their decision times."""
    result = None
    while core.sim.simt < until_s - 1e-6 and (result is None or not result.done):
        result = core.step(plan.get(round(core.sim.simt, 3), {}))


def completed(core: EpisodeCore) -> set[str]:
    return {f.acid for f in core.sim.flight_log if f.arrived}


def test_turned_away_near_its_destination_and_resumed_it_arrives():
    """Turned 40 deg right 1.2 km before TEND and resumed 10 s later, 0.73 km from it: TEND lies inside its turn
    circle (720 m), where LNAV would pass it, switch off and fly on for good (nyc_eval_678 under daa: 65 flights).
    It flies straight on until it can turn onto TEND, then arrives."""
    core = near_episode()
    uc = core.usecase
    fly(core, {60.0: {"TA1": 13}}, until_s=70.0)
    sim = core.sim
    i = sim.view.slot("TA1")
    trk = float(sim.view.trk[i])
    assert trk == pytest.approx(130.0, abs=0.5)  # the bearing to TEND (90) + 40
    assert qdrdist(sim.view.lat[i], sim.view.lon[i], *TEND)[1] == pytest.approx(734.0, abs=10.0)
    # The resume actions fly on along the track it has (what the daa baseline checks for conflicts).
    targets = uc.action_targets(sim, np.array([i]), "heading")[0]
    assert targets[uc.resume_action] == pytest.approx(trk)
    fly(core, {70.0: {"TA1": uc.resume_action}}, until_s=80.0)
    i = sim.view.slot("TA1")
    assert not sim.view.lnav[i] and float(sim.view.trk[i]) == pytest.approx(trk, abs=0.1)  # straight on
    fly(core, {})
    assert "TA1" in completed(core)
    arrival = next(f for f in sim.flight_log if f.acid == "TA1").deleted_s
    assert arrival < 200.0


def test_a_route_that_ends_short_of_the_destination_is_flown_again():
    """The autopilot itself may direct a turned aircraft to its destination from inside its turn circle (after
    passing a waypoint of its route: EVL1129 under mvp, nyc_eval_678 seed 2003). It passes the destination
    without arriving and LNAV switches off at the end of the route; at the next decision the use case sends it
    back."""
    core = near_episode()
    uc = core.usecase
    fly(core, {10.0: {"TA1": 13}, 20.0: {"TA1": uc.resume_action}}, until_s=60.0)  # turned once, far from TEND
    sim = core.sim
    i = sim.view.slot("TA1")
    assert sim.view.lnav[i]
    sim.select_heading(i, 130.0)
    sim.run_until(70.0)
    sim.resume_route(i)  # direct to TEND, 0.7 km away inside the turn circle
    missed = False
    while "TA1" in sim.view and sim.simt < 600.0:
        fly(core, {}, until_s=sim.simt + 10.0)
        i = sim.view.find("TA1")
        if i is not None and not sim.view.lnav[i]:
            missed |= qdrdist(sim.view.lat[i], sim.view.lon[i], *TEND)[1] > 0.05 * 1852.0
    assert missed  # its route ended short of TEND ...
    assert "TA1" in completed(core)  # ... and it arrived all the same


def test_an_aircraft_that_reached_its_destination_is_left_to_fly_on():
    """TB2's scenario does not remove it at TEND2: once a turned aircraft has passed within arrival_m of its
    destination, the end of its route is the scenario's, and it flies on like every other aircraft."""
    core = near_episode()
    uc = core.usecase
    fly(core, {10.0: {"TB2": 13}, 20.0: {"TB2": uc.resume_action}}, until_s=200.0)
    sim = core.sim
    i = sim.view.slot("TB2")
    assert not sim.view.lnav[i]  # its route ended at TEND2
    d0 = qdrdist(sim.view.lat[i], sim.view.lon[i], *TEND2)[1]
    fly(core, {}, until_s=400.0)
    i = sim.view.slot("TB2")
    assert not sim.view.lnav[i]
    assert qdrdist(sim.view.lat[i], sim.view.lon[i], *TEND2)[1] > d0 + 5000.0  # straight on, not sent back


def test_daa_and_mvp_baselines_bring_every_flight_home_from_the_cli(tmp_path):
    """15 flights of nyc_eval_678 (tests/data/nyc_eval_window.scn), evaluated as a user would: before, daa left 2
    of them and mvp 1 flying on past their destinations at the time limit (and, over the whole day, thousands of
    NMAC between such aircraft). Every flight arrives, with NMAC and LoWC about the unequipped aircraft's."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "rlbridge.experiment", "evaluate", "baseline=daa", f"usecase={UC}",
                           f"scenario={WINDOW}", "episodes=1", "seed=2003", "workers=0", "env.time_limit_s=1800",
                           "hydra.run.dir=eval"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
                          check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    with open(tmp_path / "eval" / "episodes.csv", newline="") as fh:
        rows = {r["policy"]: r for r in csv.DictReader(fh)}
    assert set(rows) == {"daa", "mvp", "unequipped"}
    for r in rows.values():
        assert int(r["flights_completed"]) == int(r["aircraft"]) == 15, r
    for name in ("daa", "mvp"):
        assert int(rows[name]["nmac_events"]) <= int(rows["unequipped"]["nmac_events"]) + 1
        assert int(rows[name]["lowc_events"]) <= int(rows["unequipped"]["lowc_events"]) + 2
        assert float(rows[name]["alert_rate_per_flight_hour"]) > 0  # they did turn aircraft
