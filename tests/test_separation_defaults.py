"""One separation standard for every NMAC / LoWC distance (issue 29).

The use cases' ``nmac_m`` / ``lowc_m`` (and the strategic planner's intent separation) and the
MVP baselines' protected zones default to None: the simulation's separation standard
(``sim.separation_standard``, which ``SEPVOLUME`` in a scenario changes), not a literal 150 / 450 m.
"""

from __future__ import annotations

import numpy as np
import pytest

from aamsim import SeparationStandard, Simulation
from aamsim.snapshots import TrafficSnapshot
from rlbridge.agents.baselines import KINEMATIC_FIELDS, SpeedMVPActor, SpeedMVPConfig, protected_zone
from rlbridge.usecases.registry import make_usecase
from tests.policy_digests import DATA

WIDE = SeparationStandard(300.0, 300.0, 900.0, 900.0)  # NMAC 300 m, LoWC 900 m spheres


def _corridor_on(standard: SeparationStandard | None, **params):
    sim = Simulation()
    if standard is not None:
        sim.set_separation_standard(standard)
    usecase = make_usecase("corridor_sa", **params)
    usecase.attach(sim)
    return sim, usecase


def test_the_use_case_keeps_the_simulations_standard_and_rewards_against_it():
    sim, uc = _corridor_on(WIDE)
    assert sim.separation_standard == WIDE  # attaching did not put 150 / 450 m back
    paper_sim, paper_uc = _corridor_on(None)
    closest = np.array([200.0])  # between the paper's NMAC (150 m) and WIDE's (300 m)
    # Paper: d = 200 m is outside NMAC: -alpha + delta * d = -1 + 0.0003 * 200 = -0.94, then - omega.
    assert paper_uc.rewards(paper_sim, ["A"], {}, closest, {})[0] == pytest.approx(-0.94 - 0.001)
    # WIDE: 200 m is inside NMAC: the NMAC penalty, -1, then - omega.
    assert uc.rewards(sim, ["A"], {}, closest, {})[0] == pytest.approx(-1.0 - 0.001)


def test_explicit_distances_still_set_the_simulations_standard():
    sim, _ = _corridor_on(WIDE, nmac_m=200.0)
    assert (sim.separation_standard.nmac_horizontal_m, sim.separation_standard.lowc_horizontal_m) == (200.0, 900.0)
    with pytest.raises(ValueError, match="nmac_m must be positive"):
        make_usecase("corridor_sa", nmac_m=0.0)


def test_strategic_intent_separation_is_the_simulations_lowc_distance():
    usecase = make_usecase("strategic_planning")
    sim = Simulation()
    sim.set_separation_standard(WIDE)
    assert usecase.separation_m(sim) == 900.0
    assert make_usecase("strategic_planning", separation_m=500.0).separation_m(sim) == 500.0


def _episode_events(tmp_path, extra: str, params: dict) -> tuple[int, int, int]:
    from rlbridge.agents.rollout import EnvSpec, RolloutWorker

    scn = tmp_path / f"three_way_{len(extra)}.scn"
    scn.write_text(extra + (DATA / "three_way.scn").read_text())
    worker = RolloutWorker(EnvSpec(str(scn), "corridor_sa", params, time_limit_s=900.0),
                           {"policy": {"kind": "unequipped"}})
    batch = worker.collect([0])[0]
    return batch.stats.nmac_events, batch.stats.lowc_events, int((batch.rewards <= -1.0).sum())


def test_a_scenarios_separation_volumes_change_the_use_cases_counting_and_rewards(tmp_path):
    paper = _episode_events(tmp_path, "", {})
    wide = _episode_events(tmp_path, "00:00:00.00>SEPVOLUME NMAC 2000\n00:00:00.00>SEPVOLUME LOWC 4000\n",
                           {"alt_noise_ft": 0.0})
    # The three aircraft cross within 2 km of each other: every pair is an NMAC under 2000 m, and
    # the NMAC reward penalty follows the same distance.
    assert wide[0] > paper[0] and wide[1] > paper[1]
    assert wide[2] > paper[2]


def _head_on(separation: SeparationStandard | None) -> TrafficSnapshot:
    """Two aircraft 5 km apart flying head-on (50 m/s each) on tracks 600 m apart, same altitude."""
    dlat = 600.0 / 111_195.0
    dlon = 5000.0 / (111_195.0 * np.cos(np.radians(40.7)))
    values = {"lat": [40.7, 40.7 + dlat], "lon": [-74.0, -74.0 + dlon], "alt": [300.0, 300.0],
              "gseast": [50.0, -50.0], "gsnorth": [0.0, 0.0], "vs": [0.0, 0.0], "trk": [90.0, 270.0]}
    fields = (*KINEMATIC_FIELDS, "trk")
    arr = np.array([values[f] for f in fields], dtype=np.float64)
    return TrafficSnapshot(0.0, ("A", "B"), fields, arr, separation)


def test_the_mvp_baselines_protected_zone_is_the_snapshots_lowc_distance():
    actor = SpeedMVPActor()
    assert np.isnan(actor.speed_changes(_head_on(None))).all()  # 600 m apart: clear of the paper's 450 m
    assert np.isnan(actor.speed_changes(_head_on(SeparationStandard()))).all()
    assert not np.isnan(actor.speed_changes(_head_on(WIDE))).any()  # inside WIDE's 900 m LoWC: resolved
    # An explicit radius wins over the standard's.
    assert np.isnan(SpeedMVPActor(SpeedMVPConfig(rpz_m=450.0)).speed_changes(_head_on(WIDE))).all()
    assert protected_zone(None, None, WIDE) == (900.0, 300.0)
    assert protected_zone(None, None, None) == (450.0, 150.0)


def test_an_episodes_snapshot_carries_the_simulations_standard(tmp_path):
    from rlbridge.core import EpisodeCore

    scn = tmp_path / "wide.scn"
    scn.write_text("00:00:00.00>SEPVOLUME LOWC 900\n" + (DATA / "three_way.scn").read_text())
    core = EpisodeCore(str(scn), "corridor_sa", {}, time_limit_s=60.0)
    core.reset(0)
    assert core.snapshot(("lat",)).separation == SeparationStandard(lowc_horizontal_m=900.0, lowc_vertical_m=900.0)
