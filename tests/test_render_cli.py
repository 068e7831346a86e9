"""`aamsim figure` and `aamsim view --video`, run as a user runs them."""

from __future__ import annotations

import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest

from aamsim.render.draw import TrafficPainter
from aamsim.render.video import frame_times
from aamsim.viewer.frames import STATUS_COLOURS, RunReplay
from tests.test_viewer_frames import run_dir  # noqa: F401  (fixture)


def _aamsim(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "aamsim", *args], capture_output=True, text=True, timeout=300,
                          check=False)


@pytest.fixture(scope="module")
def train_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "run"
    done = _aamsim("run", "nyc_train_100.scn", "--until", "400", "--out", str(out), "--quiet")
    assert done.returncode == 0, done.stderr
    return out


def test_aamsim_figure_draws_the_run_with_its_conflicts(train_run, tmp_path):
    out = tmp_path / "map.png"
    done = _aamsim("figure", str(train_run), "-o", str(out), "--snapshot", "200")
    assert done.returncode == 0, done.stderr
    with open(train_run / "flights.csv") as fh:
        flights = sum(1 for _ in fh) - 1
    assert f"{flights} trajectories" in done.stdout
    image = iio.imread(out)
    assert image.shape[:2] == (1500, 1500)
    lowc = np.array([int(STATUS_COLOURS[1][k:k + 2], 16) for k in (1, 3, 5)])
    # the run has LoWC events, drawn as dots in the LoWC colour
    assert (np.abs(image[..., :3].astype(int) - lowc).sum(axis=-1) < 30).sum() > 20
    bad = _aamsim("figure", str(train_run), "--snapshot", "soon")
    assert bad.returncode == 2 and "--snapshot 'soon'" in bad.stderr


def test_uam2scn_figure_is_an_alias_over_its_network(train_run, tmp_path):
    out = tmp_path / "alias.png"
    done = subprocess.run([sys.executable, "-c", "from uamtoolkit_import.cli import main; main()", "figure",
                           str(train_run), "-o", str(out), "--snapshot", "none", "--every", "5"],
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_view_video_writes_the_frames_asked_for(train_run, tmp_path):
    mp4 = tmp_path / "clip.mp4"
    done = _aamsim("view", str(train_run), "--video", str(mp4), "--from", "100", "--to", "160", "--speed", "30",
                   "--fps", "5", "--size", "320x240")
    assert done.returncode == 0, done.stderr
    frames = iio.imread(mp4)
    # 60 s at 30 sim-seconds per video second, 5 frames per second: 10 steps, 11 frames
    assert frames.shape == (11, 240, 320, 3)
    gif = tmp_path / "clip.gif"
    assert _aamsim("view", str(train_run), "--video", str(gif), "--from", "0:02:00", "--to", "130", "--speed", "10",
                   "--fps", "2").returncode == 0
    assert len(iio.imread(gif)) == 3  # 120, 125, 130 s
    for args, message in ((["--video", str(tmp_path / "x.avi")], "must end in .mp4 or .gif"),
                          (["--video", str(mp4), "--from", "300", "--to", "100"], "must come before"),
                          (["--video", str(mp4), "--speed", "-1"], "--speed must be a positive"),
                          (["--from", "10"], "go with --video")):
        bad = _aamsim("view", str(train_run), *args)
        assert bad.returncode == 2 and message in bad.stderr, (args, bad.stderr)


def test_aamsim_video_writes_the_same_frames_as_view_video(train_run, tmp_path):
    mp4, alias = tmp_path / "video.mp4", tmp_path / "view.mp4"
    done = _aamsim("video", str(train_run), "-o", str(mp4), "--from", "00:01:40", "--to", "140", "--speed", "20",
                   "--fps", "4", "--size", "240x200")
    assert done.returncode == 0, done.stderr
    assert "9 frames" in done.stdout  # 40 s at 20 sim-seconds per video second, 4 frames per second: 8 steps
    frames = iio.imread(mp4)
    assert frames.shape == (9, 200, 240, 3)
    assert _aamsim("view", str(train_run), "--video", str(alias), "--from", "100", "--to", "140", "--speed", "20",
                   "--fps", "4", "--size", "240x200").returncode == 0
    np.testing.assert_array_equal(iio.imread(alias), frames)  # one writer behind both commands
    assert not np.array_equal(frames[0], frames[-1])  # the aircraft moved
    missing = _aamsim("video", str(train_run))
    assert missing.returncode == 2 and "Missing option '-o'" in missing.stderr
    bad = _aamsim("video", str(train_run), "-o", str(tmp_path / "x.mkv"))
    assert bad.returncode == 2 and "must end in .mp4 or .gif" in bad.stderr


def test_frame_times_step_by_speed_over_fps():
    np.testing.assert_allclose(frame_times(0.0, 100.0, 10.0, 20.0, 20.0, 4.0), [10, 15, 20])
    np.testing.assert_allclose(frame_times(5.0, 7.0, None, None, 1.0, 1.0), [5, 6, 7])
    with pytest.raises(ValueError, match="outside the run"):
        frame_times(0.0, 100.0, 200.0, 300.0, 60.0, 10.0)


def test_the_painter_puts_each_aircraft_at_its_projected_pixel(run_dir):  # noqa: F811
    replay = RunReplay(run_dir)
    painter = TrafficPainter(replay.layout(), 400, 400)
    frame = replay.frame_at(10.0)
    image = painter.paint(frame)
    for lat, lon, status in zip(frame.lat, frame.lon, frame.status):
        row, col = painter.pixel(lat, lon)
        want = np.array([int(STATUS_COLOURS[status][k:k + 2], 16) for k in (1, 3, 5)])
        patch = image[row - 2:row + 3, col - 2:col + 3].reshape(-1, 3).astype(int)
        assert np.abs(patch - want).sum(axis=1).min() < 40
    with pytest.raises(ValueError, match="at least 64 x 64"):
        TrafficPainter(replay.layout(), 10, 400)


def test_evaluate_video_records_each_policy_beside_the_unequipped_baseline(tmp_path):
    import json
    import os
    from pathlib import Path

    data = Path(__file__).parent / "data"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).parent.parent) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "rlbridge.experiment", "evaluate", "baseline=mvp_speed",
                           f"scenario={data / 'tiny_conflict.scn'}", "episodes=2", "workers=0", "baselines=[]",
                           "env.time_limit_s=600", "video=true", "video_speed=60", "video_fps=5",
                           "hydra.run.dir=eval"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
                          check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    ev = tmp_path / "eval"
    videos = sorted(p.name for p in (ev / "videos").iterdir())
    assert videos == ["mvp_speed_vs_unequipped_seed-0000.mp4"]  # only the first seed; no unequipped vs itself
    frames = iio.imread(ev / "videos" / videos[0])
    assert frames.shape[1:] == (640, 1280, 3)  # two 640 x 640 panels side by side
    replays = {p: RunReplay(ev / "episodes" / p / "seed-0000") for p in ("mvp_speed", "unequipped")}
    assert len(frames) == int((max(r.t_end for r in replays.values()) - min(r.t_start for r in replays.values()))
                              / 12) + 1  # 60 sim-seconds per second of video at 5 frames per second
    # The recorded episodes are the scored ones: tiny_conflict's pair collides unequipped, MVP sequences them.
    for policy, replay in replays.items():
        summary = json.loads((ev / "episodes" / policy / "seed-0000" / "summary.json").read_text())
        nmac_lat, _ = replay.event_positions("nmac")
        assert len(nmac_lat) == summary["safety"]["nmac_events"] == (1 if policy == "unequipped" else 0)
