"""The project's files agree: one version everywhere, the licence declared is the licence shipped."""

from __future__ import annotations

import configparser
import re
from pathlib import Path

import pytest

import aamsim
import rlbridge

ROOT = Path(__file__).resolve().parent.parent


def test_one_version_in_the_package_the_citation_and_the_changelog():
    yaml = pytest.importorskip("yaml")
    assert re.fullmatch(r"\d+\.\d+\.\d+", aamsim.__version__)  # MAJOR.MINOR.PATCH (CHANGELOG.md)
    assert rlbridge.__version__ == aamsim.__version__
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert citation["cff-version"] == "1.2.0" and str(citation["version"]) == aamsim.__version__
    releases = re.findall(r"^## \[(\d+\.\d+\.\d+)\]", (ROOT / "CHANGELOG.md").read_text(), re.MULTILINE)
    assert releases and releases[0] == aamsim.__version__


def test_the_licence_file_is_the_licence_declared():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    assert cfg["metadata"]["license_expression"] == "MIT"
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    for name in cfg["metadata"]["license_files"].split():
        assert (ROOT / name).is_file(), name
    assert "MIT" in (ROOT / "CITATION.cff").read_text()


def test_torch_is_a_range_ci_pins_it_by_constraints_and_the_readme_gives_the_cpu_index():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    torch = [r for r in cfg["options.extras_require"]["rl"].split("\n") if r.strip().startswith("torch")]
    assert torch == ["torch>=2.13,<3"]
    assert "torch==2.13.0" in (ROOT / ".ci" / "constraints.txt").read_text()
    run = (ROOT / ".ci" / "run").read_text()
    # .ci/run runs the README's two commands verbatim; the pin reaches pip by PIP_CONSTRAINT only.
    assert 'export PIP_CONSTRAINT="$PWD/.ci/constraints.txt"' in run
    readme = (ROOT / "README.md").read_text()
    commands = re.findall(r"^(pip install .*?)\s{2,}#", readme, re.MULTILINE)
    assert commands == ['pip install -e . && aamsim run scn/nyc_day.scn', 'pip install -e ".[test]" && pytest']
    for command in commands:  # each step verbatim (the main job runs in a scratch directory)
        for step in command.split(" && "):
            assert f"{step} && " in run or f"&& {step}" in run, step
    assert "==" not in readme.split("## Extras")[0].split("```bash")[1].split("```")[0]
    assert "pip install torch --index-url https://download.pytorch.org/whl/cpu" in readme
    # No claim that a version pin picks the CPU build (on the public index it is the CUDA build).
    assert not re.search(r"torch==[\d.]+`? installs the CPU build", readme)
