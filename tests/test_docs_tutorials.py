"""The tutorials of the documentation site run as written (docs/tutorials/index.md states the rules).

Each page is run top to bottom by tests/doc_runner.py in a fresh folder, with the checkout's
examples/ and tests/ linked in as in a clone; a block that fails fails the page. The runner's own
rules are tested on a small page first.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.doc_runner import blocks

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted(p for p in (ROOT / "docs" / "tutorials").glob("*.md") if p.name != "index.md")
# How-to pages whose recipes are commands to run as they stand.
RECIPES = [ROOT / "docs" / "how-to" / "compare-equipped.md"]
NEEDS = {"train-sb3.md": ("stable_baselines3", "torch"), "evaluate-compare.md": ("hydra", "torch"),
         "bluesky-backend.md": ("bluesky", "hydra")}


def run_page(page: Path, workdir: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", NO_MKDOCS_2_WARNING="1")
    # The page's console scripts (aamsim, aamgym) are the ones of this interpreter's environment.
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    return subprocess.run([sys.executable, str(ROOT / "tests" / "doc_runner.py"), str(page), "--workdir",
                           str(workdir), "--clone-root", str(ROOT)], capture_output=True, text=True, env=env,
                          timeout=1200, check=False)


def test_the_seven_tutorials_of_the_issue_are_there_and_in_the_site():
    names = {p.name for p in PAGES}
    assert names == {"simulate.md", "train-sb3.md", "new-usecase.md", "evaluate-compare.md", "real-traffic.md",
                     "bluesky-backend.md", "viewer.md"}
    nav = (ROOT / "mkdocs.yml").read_text()
    assert all(f"tutorials/{n}" in nav for n in names)


def test_runner_runs_python_and_bash_in_order_writes_titled_files_and_shows_the_rest(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "Text.\n\n"
        '```python title="helper.py"\nVALUE = 41\n```\n\n'
        "```python\nfrom helper import VALUE\nx = VALUE + 1\n```\n\n"
        "```console\n$ exit 1\n```\n\n"
        "```bash\necho from-bash > out.txt\n```\n\n"
        "    ```python\n    assert x == 42\n    assert open('out.txt').read() == 'from-bash\\n'\n    ```\n")
    assert [(b.lang, b.title) for b in blocks(page.read_text())] == [
        ("python", "helper.py"), ("python", None), ("console", None), ("bash", None), ("python", None)]
    proc = run_page(page, tmp_path / "work")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (tmp_path / "work" / "helper.py").read_text() == "VALUE = 41\n"


def test_runner_stops_at_a_failing_block_naming_its_line(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```bash\ntrue\n```\n\n```bash\nfalse\n```\n\n```bash\necho never > never.txt\n```\n")
    proc = run_page(page, tmp_path / "work")
    assert proc.returncode == 1
    assert f"FAILED {page}:5: bash exited with 1" in proc.stderr
    assert not (tmp_path / "work" / "never.txt").exists()


@pytest.mark.parametrize("page", PAGES + RECIPES, ids=lambda p: p.name)
def test_page_runs_as_written(page, tmp_path):
    for module in NEEDS.get(page.name, ()):
        pytest.importorskip(module, reason=f"{page.name} needs {module} (its extra is not installed)")
    proc = run_page(page, tmp_path)
    assert proc.returncode == 0, f"{page.name} failed:\n{proc.stdout[-6000:]}\n{proc.stderr[-6000:]}"
    assert proc.stdout.rstrip().endswith("every block ran")
