"""mypy, as configured in pyproject.toml (strict for the public API modules it lists), passes over the packages:
a type regression fails the suite (issue 29)."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHECKED = ("aamsim", "uamtoolkit_import", "rlbridge")


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("mypy") is None, reason="mypy is not installed (pip install mypy)")
def test_mypy_passes_over_the_packages(tmp_path):
    # Its own cache directory: a shared .mypy_cache written by another checkout or mypy version can give
    # stale answers. A cold run over the three packages costs about 75 s of CPU (minutes of wall time on a
    # loaded machine).
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-m", "mypy", "--cache-dir", str(tmp_path / "mypy"), *CHECKED],
                         capture_output=True, text=True, cwd=ROOT, env=env, check=False)
    assert out.returncode == 0, out.stdout[-6000:] + out.stderr[-2000:]
