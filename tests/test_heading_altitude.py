"""heading_altitude_sa: tactical deconfliction by heading and altitude advisories (docs/usecases.md)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

import rlbridge
from aamsim.units import FT, R_EARTH
from rlbridge.agents import make_actor
from rlbridge.core import EpisodeCore
from rlbridge.usecases.protocol import AdvisoryKindError

HERE = Path(__file__).parent
TINY = str(HERE / "data" / "tiny_conflict.scn")
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
    assert uc.advisory_kinds == ("heading", "altitude")
    with pytest.raises(AdvisoryKindError, match=r"applying speed advisories needs speed advisories; use case "
                                                r"heading_altitude_sa does not declare them \(its advisory kinds: "
                                                r"heading, altitude\)"):
        uc.action_targets(core.sim, np.array([0]), "speed")
    result = core.step({})
    rng = np.random.default_rng(0)
    with pytest.raises(AdvisoryKindError, match="baseline mvp_speed needs speed advisories"):
        make_actor({"kind": "mvp_speed"}).act(result, core, rng, {})
    corridor = EpisodeCore(TINY, "corridor_sa", {}, time_limit_s=300.0)
    with pytest.raises(AdvisoryKindError, match=r"baseline mvp needs heading or altitude advisories; use case "
                                                r"corridor_sa does not declare them \(its advisory kinds: speed\)"):
        make_actor({"kind": "mvp"}).act(corridor.reset(0), corridor, rng, {})


def run_episode(kind: str, seed: int = 0) -> dict:
    core = engine()
    actor = make_actor({"kind": kind})
    rng = np.random.default_rng(0)
    result = core.reset(seed)
    while not result.done:
        out = actor.act(result, core, rng, {})
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
