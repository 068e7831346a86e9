"""A use case another package registers (the ``rlbridge.usecases`` entry-point group) trains by name.

The package is a module and a ``.dist-info`` folder written here on the subprocess's path (what
``pip install`` of a package declaring the entry point leaves): ``HeadingOnly``, heading
advisories only (``heading_altitude_sa`` without level changes). Before, ``aamgym train
usecase=<its name>`` failed in Hydra ("Could not find 'usecase/heading_only'"): only the built-in
use cases had a file in ``rlbridge/conf/usecase/``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytest.importorskip("hydra", reason="aamgym needs the rl extra")
pytest.importorskip("torch", reason="aamgym needs the rl extra")

ROOT = Path(__file__).resolve().parent.parent
TINY = str(ROOT / "tests" / "data" / "tiny_conflict.scn")
NAME = "heading_only"


MODULE = f"""
from typing import Any

from rlbridge.usecases.heading_altitude import HeadingAltitudeParams, HeadingAltitudeSA
from rlbridge.usecases.spec import UseCaseSpec


class HeadingOnly(HeadingAltitudeSA):
    name = "{NAME}"
    spec = UseCaseSpec(HeadingAltitudeParams, action_kinds=("heading",), baselines=("daa", "mvp"),
                       advisory="manoeuvre_change", metrics=("heading_advisories", "mean_abs_xtrack_m"))

    def __init__(self, **params: Any):
        super().__init__(**{{"heading_offsets_deg": (-30.0, 0.0, 30.0), "altitude_offsets_ft": (0.0,), **params}})

    def extra_metrics(self, sim: Any) -> dict[str, Any]:
        out = super().extra_metrics(sim)
        return {{k: out[k] for k in self.spec.metrics if k in out}}
"""


def installed_package(where: Path) -> Path:
    """A distribution that registers ``HeadingOnly`` under NAME, as an installed package would."""
    info = where / "headingonly-0.1.dist-info"
    info.mkdir(parents=True)
    (where / "headingonly.py").write_text(MODULE)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: headingonly\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[rlbridge.usecases]\n{NAME} = headingonly:HeadingOnly\n")
    return where


def aamgym(*args: str, cwd: Path, site: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), str(ROOT)]))
    return subprocess.run([sys.executable, "-m", "rlbridge.experiment", *args], cwd=cwd, capture_output=True,
                          text=True, env=env, timeout=600, check=False)


def test_aamgym_trains_a_use_case_registered_by_another_package(tmp_path: Path) -> None:
    site = installed_package(tmp_path / "site")
    proc = aamgym("train", f"usecase={NAME}", "usecase.params.n_intruders=4", "usecase.params.decision_interval_s=5",
                  f"scenario={TINY}", "workers=0", "env.time_limit_s=300", "train.baseline_episodes=1",
                  "train.iterations=2", "train.checkpoint_every=10", "algorithm=d2mava_a",
                  f"out_dir={tmp_path / 'runs'}", cwd=tmp_path, site=site)
    assert proc.returncode == 0, proc.stderr[-3000:]
    (run,) = (tmp_path / "runs" / "train").iterdir()
    config = yaml.safe_load((run / "resolved_config.yaml").read_text())
    # The use case's own defaults (HeadingAltitudeParams), with the two fields given on the command line.
    assert config["usecase"]["name"] == NAME
    assert config["usecase"]["params"]["n_intruders"] == 4 and config["usecase"]["params"]["decision_interval_s"] == 5
    assert config["usecase"]["params"]["arrival_m"] == 92.6
    assert len((run / "learning_curve.csv").read_text().splitlines()) == 1 + 2  # header, two iterations


def test_a_field_the_registered_use_case_does_not_have_is_refused_by_name(tmp_path: Path) -> None:
    site = installed_package(tmp_path / "site")
    proc = aamgym("train", f"usecase={NAME}", "usecase.params.gap_m=700", f"scenario={TINY}", "workers=0",
                  f"out_dir={tmp_path / 'runs'}", cwd=tmp_path, site=site)
    assert proc.returncode == 2
    assert "usecase.params.gap_m" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "runs").exists()


def broken_package(where: Path) -> Path:
    """A distribution whose use case cannot be imported (a dependency it lacks), as a broken install leaves."""
    info = where / "brokenuc-0.1.dist-info"
    info.mkdir(parents=True)
    (where / "brokenuc.py").write_text("import a_dependency_that_is_not_installed\n")
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: brokenuc\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[rlbridge.usecases]\nbroken_uc = brokenuc:Broken\n")
    return where


def test_a_use_case_that_fails_to_load_is_named_and_the_others_still_compose(tmp_path: Path) -> None:
    site = broken_package(tmp_path / "site")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), str(ROOT)]))
    code = ("from rlbridge.experiment.configstore import compose_config\n"
            "cfg = compose_config('config', ['usecase=reach_destination'])\n"
            "print('composed', cfg.usecase.name, cfg.usecase.params.scale_dist_m)\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, env=env,
                          timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "composed reach_destination 10000.0" in proc.stdout  # ReachParams' default
    # One warning, naming the use case, its entry point and the import error.
    assert proc.stderr.count("cannot be loaded") == 1, proc.stderr
    assert "'broken_uc' (entry point rlbridge.usecases: broken_uc = brokenuc:Broken)" in proc.stderr
    assert "No module named 'a_dependency_that_is_not_installed'" in proc.stderr
    # Asking for the broken one: the warning that says why, then Hydra's refusal; nothing is written.
    proc = aamgym("train", "usecase=broken_uc", "workers=0", f"out_dir={tmp_path / 'runs'}", cwd=tmp_path, site=site)
    assert proc.returncode != 0
    assert "No module named 'a_dependency_that_is_not_installed'" in proc.stderr
    assert "Could not find 'usecase/broken_uc'" in proc.stderr
    assert not (tmp_path / "runs").exists()
