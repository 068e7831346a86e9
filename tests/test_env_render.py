"""render_mode="rgb_array" and "human" on the PettingZoo, Gymnasium and RLlib environments."""

from __future__ import annotations

import json
import urllib.request
from pathlib import Path

import gymnasium
import imageio.v3 as iio
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.wrappers import RecordVideo
from pettingzoo.test import parallel_api_test

import rlbridge
from aamsim.viewer.frames import STATUS_COLOURS
from rlbridge.usecases.registry import available

SCENARIO = "nyc_train_100.scn"
LIMIT = 120.0  # two minutes of the training scenario: a dozen decisions


def _rgb(hex_colour: str) -> np.ndarray:
    return np.array([int(hex_colour[k:k + 2], 16) for k in (1, 3, 5)])


def test_rgb_array_draws_each_aircraft_in_its_state_colour_where_it_flies():
    env = rlbridge.parallel_env(SCENARIO, time_limit_s=LIMIT, render_mode="rgb_array", render_size=(500, 400))
    assert env.metadata["render_modes"] == ["human", "rgb_array"]
    env.reset(seed=3)
    first = env.render()
    assert first.shape == (400, 500, 3) and first.dtype == np.uint8
    for _ in range(3):
        env.step({})
    image = env.render()
    painter = env._renderer._painter
    frame = env._renderer.frame()
    assert len(frame) > 0
    for lat, lon, status in zip(frame.lat, frame.lon, frame.status):
        row, col = painter.pixel(lat, lon)
        patch = image[max(row - 3, 0):row + 4, max(col - 3, 0):col + 4].reshape(-1, 3).astype(int)
        # the triangle's body covers the aircraft's own position
        assert np.abs(patch - _rgb(STATUS_COLOURS[status])).sum(axis=1).min() < 40
    assert not np.array_equal(first, image)  # they moved
    assert painter.text.get_text().splitlines()[0] == Path(SCENARIO).stem  # the picture names its scenario
    env.close()


def test_record_video_records_an_episode_unchanged(tmp_path):
    env = gymnasium.make("aamgym/CorridorSA-v0", scenario=SCENARIO, time_limit_s=LIMIT, render_mode="rgb_array",
                         render_size=(320, 320))
    env = RecordVideo(env, str(tmp_path / "videos"), episode_trigger=lambda k: k == 0, disable_logger=True)
    env.reset(seed=1)
    steps = 0
    done = False
    while not done and steps < 8:
        _, _, term, trunc, _ = env.step(1)
        steps += 1
        done = term or trunc
    env.close()
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 1
    frames = iio.imread(videos[0])
    assert frames.shape[1:] == (320, 320, 3)
    assert len(frames) == steps + 1  # the reset's picture and one per step


@pytest.mark.parametrize("mode", ["rgb_array", "human"])
def test_the_api_checkers_pass_with_each_render_mode(mode):
    env = gymnasium.make("aamgym/CorridorSA-v0", scenario=SCENARIO, time_limit_s=LIMIT, render_mode=mode,
                         render_size=(200, 200))
    check_env(env.unwrapped)  # made with a spec: the checker also tries the other render mode
    env.close()
    penv = rlbridge.parallel_env(SCENARIO, time_limit_s=LIMIT, render_mode=mode, render_size=(200, 200))
    parallel_api_test(penv, num_cycles=20)
    penv.close()


def test_human_mode_publishes_every_step_to_the_web_viewer():
    env = rlbridge.parallel_env(SCENARIO, time_limit_s=LIMIT, render_mode="human")
    env.reset(seed=2)
    url = env._renderer.url
    assert url is not None and url.startswith("http://127.0.0.1:")
    with urllib.request.urlopen(url + "api/status") as res:
        before = json.loads(res.read())["published"]
    env.step({})
    env.step({})
    with urllib.request.urlopen(url + "api/status") as res:
        after = json.loads(res.read())["published"]
    assert after == before + 2
    with urllib.request.urlopen(url + "api/frame") as res:
        frame = json.loads(res.read())
    assert sorted(frame["ids"]) == sorted(env.core.sim.view.ids)
    env.close()


def test_the_rllib_env_renders_through_its_config():
    from rlbridge.rllib_env import AamMultiAgentEnv

    env = AamMultiAgentEnv({"scenario": SCENARIO, "time_limit_s": LIMIT, "render_mode": "rgb_array",
                            "render_size": (240, 240)})
    env.reset(seed=0)
    assert env.render().shape == (240, 240, 3)
    env.close()


def test_an_unknown_render_mode_is_refused_with_the_known_ones():
    with pytest.raises(ValueError, match="'ansi'.*human, rgb_array"):
        rlbridge.parallel_env(SCENARIO, render_mode="ansi")


def test_without_a_render_mode_render_returns_none():
    env = rlbridge.parallel_env(SCENARIO, time_limit_s=LIMIT)
    env.reset(seed=0)
    assert env.render() is None
    env.close()


@pytest.mark.parametrize("usecase", available())
def test_every_use_case_renders_its_traffic(usecase):
    env = rlbridge.parallel_env(SCENARIO, usecase=usecase, time_limit_s=300.0, render_mode="rgb_array",
                                render_size=(200, 200))
    env.reset(seed=1)
    before = env.render()
    env.step({a: env.action_space(a).sample() for a in env.agents})
    after = env.render()
    assert before.shape == after.shape == (200, 200, 3)
    assert not np.array_equal(before, after)  # the traffic moved (or a flight was released)
    env.close()
