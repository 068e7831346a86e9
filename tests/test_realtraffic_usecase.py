"""Real traffic overlaid in the use cases: the replayed aircraft is an intruder in the observations,
never an agent, and its encounters count in the rewards."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from rlbridge.envs import AamParallelEnv
from rlbridge.usecases.corridor import CorridorParams
from rlbridge.usecases.reach import ReachParams

R_EARTH = 6371000.0
HEADER = "time,icao24,lat,lon,velocity,heading,vertrate,callsign,onground,baroaltitude\n"


@pytest.fixture
def overlay_case(tmp_path: Path) -> tuple[Path, Path]:
    """UAM1 hovers at (47.0, 8.0, 1640 ft); the recorded aircraft eee001 stays at (47.01, 8.0, 500 m)."""
    scn = tmp_path / "hover.scn"
    scn.write_text("00:00:00.00>CRE UAM1 EC35 47.0 8.0 0 1640 0\n")
    rec = tmp_path / "rec.csv"
    rec.write_text(HEADER + "".join(f"{5000 + t},eee001,47.01,8.0,0,0,0,HELI,false,500\n" for t in range(0, 400, 10)))
    return scn, rec


def test_corridor_observes_the_replayed_aircraft_as_an_intruder(overlay_case):
    scn, _rec = overlay_case
    env = AamParallelEnv(str(scn), obs_format="dict", n_intruders=3, overlay="rec.csv", time_limit_s=120.0,
                         alt_noise_ft=0.0)  # fixed traffic: the hand-computed geometry
    obs, _ = env.reset(seed=1)
    assert env.agents == ["UAM1"]  # the replayed aircraft is not an agent
    assert "RTEEE001" not in env.possible_agents
    intruders, mask = obs["UAM1"]["intruders"], obs["UAM1"]["mask"]
    assert mask.tolist() == [1.0, 0.0, 0.0]
    north = R_EARTH * math.radians(0.01)  # 1,111.95 m north, same longitude
    dz = 500.0 - 1640 * 0.3048
    # x, y, z relative (scaled by 5000 m and 100 m), its acceleration, speed (hovering), distance.
    assert intruders[0, 0] == pytest.approx(0.0, abs=1e-6)
    assert intruders[0, 1] == pytest.approx(north / 5000.0, rel=1e-5)
    assert intruders[0, 2] == pytest.approx(dz / 100.0, rel=1e-4)
    assert intruders[0, 4] == pytest.approx(0.0, abs=1e-6)
    assert intruders[0, 6] == pytest.approx(math.hypot(north, dz) / 5000.0, rel=1e-5)
    # Its reward term: -alpha + delta * d for the closest intruder within d_max (3 km), minus omega.
    _, rewards, _, _, _ = env.step({"UAM1": 1})
    assert rewards["UAM1"] == pytest.approx(-1.0 + 0.0003 * math.hypot(north, dz) - 0.001, rel=1e-5)
    env.close()


def test_without_overlay_there_is_no_intruder(overlay_case):
    scn, _ = overlay_case
    env = AamParallelEnv(str(scn), obs_format="dict", n_intruders=3, time_limit_s=60.0)
    obs, _ = env.reset(seed=1)
    assert obs["UAM1"]["mask"].tolist() == [0.0, 0.0, 0.0]
    env.close()


def test_reach_destination_takes_an_overlay(overlay_case):
    scn, rec = overlay_case
    env = AamParallelEnv(str(scn), usecase="reach_destination", overlay=str(rec), time_limit_s=60.0)
    env.reset(seed=0)
    assert env.agents == ["UAM1"]
    assert "RTEEE001" in env.core.sim.view
    env.close()


def test_overlay_parameters_are_checked():
    with pytest.raises(ValueError, match="overlay_area is 4 numbers"):
        CorridorParams(overlay="x.csv", overlay_area=(47.0, 8.0))
    with pytest.raises(ValueError, match="overlay_area is 4 numbers"):
        ReachParams(overlay_area=(1.0,))
    assert CorridorParams(overlay_area=[47, 8, 48, 9]).overlay_area == (47.0, 8.0, 48.0, 9.0)


def test_hydra_configs_name_the_overlay():
    from omegaconf import OmegaConf

    from rlbridge.experiment.configstore import compose_config

    # The use-case YAML files list only preset changes; the composed config carries every parameter.
    for name, cls in (("corridor_sa", CorridorParams), ("reach_destination", ReachParams)):
        params = OmegaConf.to_container(compose_config("config", [f"usecase={name}"]).usecase.params)
        assert params["overlay"] == "" and params["overlay_area"] == []
        cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in params.items()})  # every key is a parameter
