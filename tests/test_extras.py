"""A feature whose extra is not installed says which extra, in one line (issue 30, item 2).

The end-to-end check, in a fresh environment where the extras really are missing, is
tests/test_packaging.py; here the pieces, with modules hidden the way Python sees a missing one.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from aamsim.extras import EXTRAS, MissingExtra, missing, require

ROOT = Path(__file__).resolve().parents[1]


def test_require_names_the_feature_the_missing_modules_and_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(MissingExtra) as exc:
        require("batch", "aamsim batch", hint="or --no-ray")
    assert str(exc.value) == 'aamsim batch needs ray, which is not installed: pip install "aamsim[batch]" (or --no-ray)'
    assert isinstance(exc.value, ImportError) and exc.value.extra == "batch"
    assert missing(["json", "ray", "no_such_module_here"]) == ["ray", "no_such_module_here"]
    with pytest.raises(KeyError, match="unknown extra"):
        require("gpu", "x")


def test_every_extra_of_setup_cfg_is_described():
    import configparser

    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    declared = set(cfg["options.extras_require"]) - {"all", "test"}
    assert declared == set(EXTRAS)


HIDE = "import sys\nfor m in {mods!r}:\n    sys.modules[m] = None\n"


def run_hidden(mods: list[str], code: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", HIDE.format(mods=mods) + code], capture_output=True, text=True,
                          env=env, cwd=tmp_path, timeout=600, check=False)


def test_aamsim_batch_without_ray_exits_2_with_one_line(tmp_path):
    proc = run_hidden(["ray"], "from aamsim.cli import main\nmain(['batch', 'merge_conflict'])", tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        ('error: aamsim batch needs ray, which is not installed: pip install "aamsim[batch]" '
         "(or --no-ray: the runs one by one in this process)")]


def test_aamgym_without_torch_names_the_rl_extra(tmp_path):
    proc = run_hidden(["torch"], "from rlbridge.experiment.cli import main\nmain(['train', 'algorithm=ddqn'])", tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        'aamgym train: error: aamgym train needs torch, which is not installed: pip install "aamsim[rl]"']
    helped = run_hidden(["torch", "hydra"], "from rlbridge.experiment.cli import main\nmain(['--help'])", tmp_path)
    assert helped.returncode == 0
    assert helped.stdout.strip().splitlines()[-1] == (
        'These commands need the rl extra (torch, hydra not installed): pip install "aamsim[rl]"')
    # --version needs no extra and answers as aamsim's and uam2scn's do.
    version = run_hidden(["torch", "hydra"], "from rlbridge.experiment.cli import main\nmain(['--version'])", tmp_path)
    from aamsim import __version__
    assert version.returncode == 0 and version.stdout.strip() == f"aamgym, version {__version__}", version.stderr


def test_mp4_without_imageio_ffmpeg_names_the_video_extra_and_gif_still_works(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, "-m", "aamsim", "run", "merge_conflict", "--out", "r", "--quiet"], cwd=tmp_path,
                   env=env, check=True, timeout=600)
    code = "from aamsim.cli import main\nmain(['video', 'r', '-o', '{out}', '--speed', '60', '--fps', '2'])"
    mp4 = run_hidden(["imageio_ffmpeg"], code.format(out="x.mp4"), tmp_path)
    assert mp4.returncode == 2
    assert mp4.stderr.strip().splitlines()[-1] == (
        'error: an MP4 video (x.mp4) needs imageio_ffmpeg, which is not installed: pip install "aamsim[video]" '
        "(or write a .gif)")
    assert not (tmp_path / "x.mp4").exists()
    gif = run_hidden(["imageio_ffmpeg"], code.format(out="x.gif"), tmp_path)
    assert gif.returncode == 0, gif.stderr
    assert (tmp_path / "x.gif").read_bytes()[:6] == b"GIF89a"


def test_record_video_without_moviepy_names_the_video_extra(tmp_path):
    code = ("import gymnasium, rlbridge\nfrom rlbridge.render import record_video\n"
            "env = gymnasium.make('aamgym/CorridorSA-v1', scenario='merge_conflict', render_mode='rgb_array')\n"
            "record_video(env, 'videos')\n")
    proc = run_hidden(["moviepy"], code, tmp_path)
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1] == (
        'aamsim.extras.MissingExtra: gymnasium.wrappers.RecordVideo needs moviepy, which is not installed: '
        'pip install "aamsim[video]"')


def test_record_video_with_moviepy_is_gymnasiums_wrapper(tmp_path):
    pytest.importorskip("moviepy")
    import gymnasium

    import rlbridge  # noqa: F401
    from rlbridge.render import record_video

    env = record_video(gymnasium.make("aamgym/CorridorSA-v1", scenario="merge_conflict", render_mode="rgb_array"),
                       tmp_path / "videos", episode_trigger=lambda k: False)
    assert isinstance(env, gymnasium.wrappers.RecordVideo)
    env.close()


def test_bluesky_backend_without_bluesky_names_the_bluesky_extra(tmp_path):
    code = "import rlbridge\nrlbridge.parallel_env('merge_conflict', backend='bluesky')\n"
    proc = run_hidden(["bluesky"], code, tmp_path)
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1].endswith(
        'backend="bluesky" needs bluesky, which is not installed: pip install "aamsim[bluesky]"')


def test_rllib_adapter_without_ray_names_the_rl_extra(tmp_path):
    proc = run_hidden(["ray"], "import rlbridge.rllib_env\n", tmp_path)
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1].endswith('needs ray, which is not installed: pip install "aamsim[rl]"')
