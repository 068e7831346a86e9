"""The documentation site builds with warnings as errors, holds every page, and cites only files that exist."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
# A repository path in backticks: `rlbridge/conf/config.yaml`, `tests/data/tiny_conflict.scn`, ...
CITED = re.compile(r"`((?:aamsim|rlbridge|uamtoolkit_import|tests|docs|examples|bench|scripts|seed)/"
                   r"[A-Za-z0-9_./-]+\.(?:py|md|scn|json|tex|yaml|csv|gz|sh|js|html|cff))`")


def mkdocs(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    return subprocess.run([sys.executable, "-m", "mkdocs", *args], cwd=cwd, capture_output=True, text=True,
                          env=env, timeout=900, check=False)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    pytest.importorskip("mkdocs", reason="the docs extra is not installed (pip install -e '.[docs]')")
    pytest.importorskip("mkdocstrings", reason="the docs extra is not installed")
    out = tmp_path_factory.mktemp("site")
    proc = mkdocs("build", "--strict", "-f", str(ROOT / "mkdocs.yml"), "-d", str(out), cwd=ROOT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def test_site_builds_strictly_with_an_api_reference_from_the_docstrings(site):
    api = (site / "reference" / "aamsim" / "index.html").read_text()
    assert 'id="aamsim.simulation.Simulation"' in api
    assert "Run the command line" not in api  # private helpers stay out; public objects are in
    assert 'id="aamsim.extras.MissingExtra"' in api
    agents = (site / "reference" / "agents" / "index.html").read_text()
    assert 'id="rlbridge.agents.ddqn.DDQNConfig"' in agents and 'id="rlbridge.experiment.schema.TrainConfig"' in agents
    for page in ("getting-started", "tutorials/simulate", "concepts/backends", "how-to/compare-equipped"):
        assert (site / page / "index.html").is_file(), page


def test_every_markdown_page_is_in_the_navigation():
    nav = (ROOT / "mkdocs.yml").read_text().split("\nnav:", 1)[1]
    pages = [p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")]
    fragments = {p for p in pages if p.startswith("results/") and p != "results/report.md"}  # tables of report.md
    missing = [p for p in pages if p not in fragments and p not in nav]
    assert not missing, f"pages not in mkdocs.yml's nav: {missing}"


def test_strict_build_fails_on_a_broken_link(tmp_path):
    """The same validation settings as mkdocs.yml turn a link to a missing page into a failed build."""
    pytest.importorskip("mkdocs", reason="the docs extra is not installed")
    config = (ROOT / "mkdocs.yml").read_text()
    validation = config[config.index("validation:"):config.index("\nnav:")]
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "index.md").write_text("# Home\n\nSee [the missing page](missing.md).\n")
    (tmp_path / "mkdocs.yml").write_text(f"site_name: t\nstrict: true\n{validation}\nnav:\n  - index.md\n")
    proc = mkdocs("build", "-d", str(tmp_path / "site"), cwd=tmp_path)
    assert proc.returncode != 0
    assert "missing.md" in proc.stderr


def test_the_docs_cite_only_files_that_exist():
    pages = [*DOCS.rglob("*.md"), ROOT / "README.md"]
    missing = [(p.relative_to(ROOT).as_posix(), m) for p in pages for m in CITED.findall(p.read_text())
               if not (ROOT / m).exists()]
    assert not missing, missing


def test_readme_counts_the_vertiports_of_the_shipped_network():
    from uamtoolkit_import.netfile import nyc_network

    n = len(nyc_network().vertiports)
    readme = (ROOT / "README.md").read_text()
    assert f"{n} vertiports" in readme
    assert not re.search(rf"\b(?!{n}\b)\d+ vertiports", readme)


# Commands of the README that need an extra, and the extra.
NEEDS_EXTRA = {"aamsim batch": "batch", "aamgym ": "rl", "sb3_ppo": "rl", "rllib_ppo": "rl", ".mp4": "video",
               'backend="bluesky"': "bluesky", "RecordVideo": "video"}


def test_readme_presents_a_command_that_needs_an_extra_only_with_its_extra():
    """After `pip install -e .` a reader may run any README command shown without an extra; the others say
    which extra they need, in the text just before their block or on their own line."""
    from tests.doc_runner import blocks

    lines = (ROOT / "README.md").read_text().splitlines()
    previous_end = 0
    unnamed = []
    for block in blocks("\n".join(lines)):
        before = "\n".join(lines[previous_end:block.line - 1])
        for line in block.code.splitlines():
            for command, extra in NEEDS_EXTRA.items():
                named = f"[{extra}" in before or f"`{extra}` extra" in before or f"{extra} extra" in line
                if command in line and not named:
                    unnamed.append(f"README.md:{block.line}: {line.strip()} (needs the {extra} extra)")
        previous_end = block.line + block.code.count("\n") + 1
    assert not unnamed, "\n".join(unnamed)
