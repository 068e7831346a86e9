"""The package as a user gets it: built with ``python -m build``, installed from the wheel into a fresh
virtual environment outside the source tree, with no extra.

The wheel and the sdist are built once per session, and one fresh environment is made for the whole
session (building and installing take minutes): the main job runs from it, the console scripts
answer, and every feature whose extra is missing ends in one line naming the extra.
"""

from __future__ import annotations

import configparser
import email
import json
import os
import subprocess
import sys
import tarfile
import zipfile
from importlib.metadata import version
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.slow


def run(cmd: list[str], cwd: Path, timeout: float = 900, **env: str) -> subprocess.CompletedProcess[str]:
    full_env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    full_env.update(env)
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout, env=full_env, check=False)


@pytest.fixture(scope="session")
def dist(tmp_path_factory) -> dict[str, Path | str]:
    """``python -m build``: the sdist, then the wheel built from it (what an index receives), and the log."""
    pytest.importorskip("build", reason="the build tool is not installed (it is in the test extra)")
    out = tmp_path_factory.mktemp("dist")
    proc = run([sys.executable, "-m", "build", "--outdir", str(out), str(ROOT)], cwd=out)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
    (wheel,) = out.glob("aamsim-*.whl")
    (sdist,) = out.glob("aamsim-*.tar.gz")
    return {"wheel": wheel, "sdist": sdist, "log": proc.stdout + proc.stderr}


@pytest.fixture(scope="session")
def venv(dist, tmp_path_factory) -> Path:
    """A fresh virtual environment outside the tree with the wheel installed: the base install.

    Made once and shared by every test of the installed package. ``--no-compile`` skips writing
    bytecode for every dependency at install time (Python writes it on first import anyway): the
    packages installed and their versions are the same.
    """
    where = tmp_path_factory.mktemp("fresh")
    proc = run([sys.executable, "-m", "venv", str(where / "venv")], cwd=where)
    assert proc.returncode == 0, proc.stderr
    pip = run([str(where / "venv" / "bin" / "python"), "-m", "pip", "install", "--quiet", "--no-compile",
               "--disable-pip-version-check", str(dist["wheel"])], cwd=where, timeout=1800)
    assert pip.returncode == 0, pip.stdout[-4000:] + pip.stderr[-4000:]
    return where / "venv"


@pytest.fixture(scope="session")
def user_dir(tmp_path_factory) -> Path:
    """An empty folder to run from, nowhere near the checkout."""
    return tmp_path_factory.mktemp("user")


def script(venv: Path, name: str) -> str:
    return str(venv / "bin" / name)


def last_line(proc: subprocess.CompletedProcess[str]) -> str:
    lines = [line for line in (proc.stdout + proc.stderr).splitlines() if line.strip()]
    return lines[-1] if lines else ""


# ---- the artefacts ---------------------------------------------------------------------------------


def test_build_declares_every_package_it_ships(dist):
    log = str(dist["log"])
    assert "Package would be ignored" not in log
    assert "is absent from the `packages` configuration" not in log


def test_wheel_holds_the_package_data_and_the_licence(dist):
    names = zipfile.ZipFile(dist["wheel"]).namelist()
    for wanted in ("aamsim/scn/nyc_day.scn", "aamsim/scn/merge_conflict.scn", "aamsim/traffic/data/performance.json",
                   "aamsim/viewer/static/viewer.js", "aamsim/py.typed", "rlbridge/conf/config.yaml",
                   "rlbridge/conf/algorithm/ddqn.yaml", "rlbridge/conf/usecase/corridor_sa.yaml",
                   "uamtoolkit_import/data/nyc_network.json", "aamsim_bluesky.pth"):
        assert wanted in names, wanted
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    assert not any(n.startswith(("tests/", "docs/", "examples/")) for n in names)


def test_wheel_metadata_declares_licence_pythons_ranges_and_extras(dist):
    with zipfile.ZipFile(dist["wheel"]) as whl:
        meta_name = next(n for n in whl.namelist() if n.endswith(".dist-info/METADATA"))
        meta = email.message_from_bytes(whl.read(meta_name))
    assert meta["License-Expression"] == "MIT"
    classifiers = meta.get_all("Classifier")
    for minor in ("3.11", "3.12", "3.13"):
        assert f"Programming Language :: Python :: {minor}" in classifiers
    extras = set(meta.get_all("Provides-Extra"))
    assert {"rl", "batch", "video", "realtraffic", "bluesky", "bluesky-gym", "docs", "all", "test"} <= extras
    requires = meta.get_all("Requires-Dist")
    base = [r for r in requires if "extra ==" not in r]
    assert not any(r.startswith(("scipy", "imageio-ffmpeg", "imageio_ffmpeg", "torch")) for r in base), base
    torch = [r.split(";")[0] for r in requires if r.startswith("torch")]
    assert torch and all("==" not in r and ">=" in r for r in torch), torch  # a range, never a pin


def test_sdist_holds_tests_with_their_data_docs_examples_and_project_files(dist):
    with tarfile.open(dist["sdist"]) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
    for wanted in ("LICENSE", "NOTICE.md", "CHANGELOG.md", "CITATION.cff", "mkdocs.yml", "README.md",
                   "tests/data/tiny_conflict.scn", "tests/data/opensky/rega_zh.json.gz",
                   "tests/conformance/reference/straight.json", "tests/conformance/scenarios/straight.scn",
                   "tests/doc_runner.py", "docs/index.md", "docs/tutorials/simulate.md", "docs/metrics.md",
                   "examples/sb3_ppo.py", "examples/zurich_real_traffic/zurich_0800.scn", ".importlinter"):
        assert wanted in names, wanted


def test_sdist_tests_pass_with_the_data_it_ships(dist, tmp_path):
    """Tests that read tests/data run from the unpacked sdist alone (the checkout is not on the path)."""
    with tarfile.open(dist["sdist"]) as tar:
        tar.extractall(tmp_path, filter="data")
    (src,) = tmp_path.glob("aamsim-*")
    proc = run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests/test_realtraffic_readers.py",
                "tests/test_shipped_scenarios_disjoint.py"], cwd=src, PYTHONPATH=str(src))
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
    assert " passed" in proc.stdout


# ---- the base install, from outside the tree --------------------------------------------------------


def test_base_install_is_the_simulator_without_the_extras(venv):
    proc = run([str(venv / "bin" / "python"), "-m", "pip", "list", "--format=json"], cwd=venv)
    installed = {p["name"].lower(): p["version"] for p in json.loads(proc.stdout)}
    assert "aamsim" in installed
    for absent in ("torch", "ray", "scipy", "imageio-ffmpeg", "moviepy", "pyarrow", "bluesky-simulator",
                   "hydra-core", "stable-baselines3"):
        assert absent not in installed, absent
    # The second README command installs the extras on top of the first one's packages without
    # moving them: the versions the extras bound resolve the same in both.
    for name in ("gymnasium", "pillow"):
        assert installed[name] == version(name), (name, installed[name], version(name))


def test_main_job_and_help_run_from_the_installed_wheel(venv, user_dir):
    proc = run([script(venv, "aamsim"), "run", "scn/nyc_day.scn", "--until", "600", "--out", "nyc", "--quiet"],
               cwd=user_dir, timeout=1800)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    summary = json.loads((user_dir / "nyc" / "summary.json").read_text())
    assert summary["sim_time_s"] == 600.0 and summary["flights_created"] > 0 and summary["errors"] == 0
    assert str(venv) in summary["scenario_file"]  # the scenario shipped in the wheel, not the checkout's

    help_ = run([script(venv, "aamsim"), "--help"], cwd=user_dir)
    assert help_.returncode == 0 and "run" in help_.stdout and "batch" in help_.stdout

    gym_help = run([script(venv, "aamgym"), "--help"], cwd=user_dir)
    assert gym_help.returncode == 0, gym_help.stderr
    assert "train" in gym_help.stdout
    assert 'pip install "aamsim[rl]"' in last_line(gym_help)


def test_environments_run_in_the_base_install(venv, user_dir):
    code = ("import gymnasium, rlbridge\n"
            "env = gymnasium.make('aamgym/CorridorSA-v1', scenario='merge_conflict', time_limit_s=300.0)\n"
            "obs, _ = env.reset(seed=0)\n"
            "done = False\n"
            "while not done:\n"
            "    obs, r, term, trunc, _ = env.step(1)\n"
            "    done = term or trunc\n"
            "print('episode done', obs.shape)\n")
    proc = run([str(venv / "bin" / "python"), "-c", code], cwd=user_dir)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "episode done" in proc.stdout


@pytest.fixture(scope="module")
def a_run(venv, user_dir) -> Path:
    out = user_dir / "merge"
    if not out.exists():
        proc = run([script(venv, "aamsim"), "run", "merge_conflict", "--out", str(out), "--quiet"], cwd=user_dir)
        assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="module")
def parquet_recording(user_dir) -> Path:
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    from aamsim.realtraffic import read_reports

    rega = read_reports(ROOT / "tests" / "data" / "opensky" / "rega_zh.json.gz")
    table = pa.table({"timestamp": rega.t_s, "icao24": list(rega.icao24), "latitude": rega.lat,
                      "longitude": rega.lon, "altitude": rega.alt_m / 0.3048})
    path = user_dir / "rega.parquet"
    pq.write_table(table, path)
    return path


MISSING = {
    "aamsim batch": (["aamsim", "batch", "merge_conflict"], "batch"),
    "aamgym train": (["aamgym", "train", "algorithm=ddqn"], "rl"),
    "aamgym evaluate": (["aamgym", "evaluate", "baseline=daa", "scenario=merge_conflict"], "rl"),
    "aamgym report": (["aamgym", "report", "x"], "rl"),
    "aamgym study": (["aamgym", "study", "--plan"], "rl"),
    "aamsim video mp4": (["aamsim", "video", "{run}", "-o", "x.mp4"], "video"),
    "aamsim view --video mp4": (["aamsim", "view", "{run}", "--video", "x.mp4"], "video"),
    "RecordVideo": (["python", "-c", ("import gymnasium, rlbridge\nfrom rlbridge.render import record_video\n"
                                      "env = gymnasium.make('aamgym/CorridorSA-v1', scenario='merge_conflict', "
                                      "render_mode='rgb_array')\nrecord_video(env, 'videos')")], "video"),
    "parquet overlay": (["aamsim", "run", "merge_conflict", "--overlay", "{parquet}", "--out", "p"], "realtraffic"),
    "bluesky backend": (["python", "-c", "import rlbridge\nrlbridge.parallel_env('merge_conflict', backend='bluesky')"],
                        "bluesky"),
    "RLlib adapter": (["python", "-c", "import rlbridge.rllib_env"], "rl"),
    "SB3 example": (["python", str(ROOT / "examples" / "sb3_ppo.py"), "--steps", "10"], "rl"),
    "RLlib example": (["python", str(ROOT / "examples" / "rllib_ppo.py")], "rl"),
}


@pytest.mark.parametrize("feature", list(MISSING))
def test_a_feature_without_its_extra_ends_in_one_line_naming_it(feature, venv, user_dir, a_run, request):
    cmd, extra = MISSING[feature]
    values = {"run": str(a_run)}
    if any("{parquet}" in c for c in cmd):
        values["parquet"] = str(request.getfixturevalue("parquet_recording"))
    argv = [script(venv, cmd[0]), *(c.format(**values) for c in cmd[1:])]
    proc = run(argv, cwd=user_dir)
    assert proc.returncode != 0
    line = last_line(proc)
    assert f'pip install "aamsim[{extra}]"' in line, proc.stdout[-2000:] + proc.stderr[-2000:]
    if cmd[0] != "python":  # a console script prints the line alone, without a traceback
        assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
        assert proc.returncode == 2


def test_batch_without_ray_runs_with_no_ray(venv, user_dir):
    proc = run([script(venv, "aamsim"), "batch", "merge_conflict", "--seeds", "2", "--no-ray", "--out", "b",
                "--quiet"], cwd=user_dir)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "ci95_low" in (user_dir / "b" / "aggregate.csv").read_text()  # Student's t without SciPy


def test_setup_cfg_test_extra_is_every_extra_plus_the_tools():
    cfg = configparser.ConfigParser(interpolation=None)
    cfg.read(ROOT / "setup.cfg")
    extras = cfg["options.extras_require"]
    assert "%(all)s" in extras["test"] and "%(docs)s" in extras["test"]
    for name in ("rl", "batch", "video", "realtraffic", "bluesky", "bluesky-gym"):
        assert f"%({name})s" in extras["all"]
    constraints = (ROOT / ".ci" / "constraints.txt").read_text()
    assert "torch==2.13.0" in constraints
