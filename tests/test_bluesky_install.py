"""``import bluesky`` on aamsim: ``install()``, ``AAMSIM_BLUESKY=1``, ``python -m aamsim.compat.bluesky``.

Each case runs in a fresh Python process, since what ``import bluesky`` gives
is the process's business: the real BlueSky in one, the shim in another, and
both side by side in a third (the shim imported as ``aamsim.compat.bluesky``).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HAS_BLUESKY = importlib.util.find_spec("bluesky") is not None
needs_bluesky = pytest.mark.skipif(not HAS_BLUESKY, reason="bluesky-simulator is not installed")


def _python(code: str, *args: str, env: dict[str, str] | None = None, cwd: Path | None = None) -> str:
    base = {k: v for k, v in os.environ.items() if k != "AAMSIM_BLUESKY"}
    base["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    proc = subprocess.run([sys.executable, *args, "-c", textwrap.dedent(code)] if code else [sys.executable, *args],
                          capture_output=True, text=True, env={**base, **(env or {})}, cwd=cwd, timeout=300,
                          check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout.strip().splitlines()[-1]


@pytest.mark.bluesky
@needs_bluesky
def test_without_install_import_bluesky_is_the_real_one():
    out = _python("""
        import aamsim.compat.bluesky  # imported, not installed: changes nothing
        import bluesky
        print(bluesky.__name__, "aamsim" in bluesky.__file__)
    """)
    assert out == "bluesky False"


def test_install_makes_bluesky_and_its_submodules_the_shim():
    out = _python("""
        import sys
        import aamsim.compat.bluesky as shim
        shim.install()
        import bluesky as bs
        import bluesky.simulation, bluesky.tools.geo
        from bluesky.simulation import ScreenIO
        from bluesky.tools import areafilter
        assert bs is shim and bluesky.simulation is sys.modules["aamsim.compat.bluesky.simulation"]
        assert areafilter is sys.modules["aamsim.compat.bluesky.tools.areafilter"]
        try:
            import bluesky.network.detached
        except NotImplementedError as exc:
            assert "bluesky.network" in str(exc) and "docs/bluesky-api.md" in str(exc) and isinstance(exc, ImportError)
        else:
            raise AssertionError("bluesky.network imported")
        bs.init(mode="sim", detached=True)
        bs.traf.cre("KL001", actype="A320", acspd=150.0)
        bs.stack.stack("DT 5")
        bs.sim.step()
        shim.uninstall()
        assert "bluesky" not in sys.modules and not shim.installed()
        print(bs.sim.simt, bs.traf.id)
    """)
    assert out == "5.0 ['KL001']"


@pytest.mark.bluesky
@needs_bluesky
def test_install_after_the_real_bluesky_is_refused():
    out = _python("""
        import bluesky
        import aamsim.compat.bluesky as shim
        try:
            shim.install()
        except RuntimeError as exc:
            print("refused" if "imported in this process already" in str(exc) else exc)
    """)
    assert out == "refused"


@pytest.mark.bluesky
@needs_bluesky
def test_real_bluesky_and_the_shim_side_by_side_in_one_process():
    out = _python("""
        import bluesky as real
        import aamsim.compat.bluesky as shim
        real.init(mode="sim", detached=True)
        shim.init(mode="sim", detached=True)
        for bs in (real, shim):
            bs.traf.cre("KL001", actype="A320", aclat=52.0, aclon=4.0, achdg=90.0, acalt=3000.0, acspd=150.0)
            bs.stack.stack("DT 1")
            for _ in range(60):
                bs.sim.step()
        print(abs(real.traf.lon[0] - shim.traf.lon[0]) < 1e-9, real.sim.simt == shim.sim.simt == 60.0)
    """)
    assert out == "True True"


def _startup_dir(tmp_path: Path) -> Path:
    """A site directory holding the startup hook that the installation puts in site-packages."""
    site_dir = tmp_path / "site"
    site_dir.mkdir()
    shutil.copy(ROOT / "aamsim_bluesky.pth", site_dir)
    return site_dir


@pytest.mark.parametrize(("value", "expected"), [("1", "aamsim.compat.bluesky"), ("", "not installed"),
                                                 ("0", "not installed")])
def test_the_environment_variable_installs_the_shim_at_startup(tmp_path, value, expected):
    site_dir = _startup_dir(tmp_path)
    out = _python(f"""
        import site, sys
        site.addsitedir({str(site_dir)!r})  # what Python does with site-packages at startup
        import aamsim.compat.bluesky as shim
        print(sys.modules["bluesky"].__name__ if shim.installed() and __import__("bluesky") else "not installed")
    """, env={"AAMSIM_BLUESKY": value} if value else None)
    assert out == expected


def test_an_environment_value_not_understood_is_reported_and_ignored(tmp_path):
    site_dir = _startup_dir(tmp_path)
    code = f"import site; site.addsitedir({str(site_dir)!r}); import aamsim.compat.bluesky as s; print(s.installed())"
    proc = subprocess.run([sys.executable, "-c", code],
                          capture_output=True, text=True, timeout=300, check=False,
                          env={**os.environ, "AAMSIM_BLUESKY": "maybe", "PYTHONPATH": str(ROOT)})
    assert proc.stdout.strip() == "False" and "AAMSIM_BLUESKY='maybe' is not understood" in proc.stderr


def test_python_m_runs_a_script_on_the_shim(tmp_path):
    script = tmp_path / "train.py"
    script.write_text("import sys\nimport bluesky\nprint(bluesky.__name__, sys.argv[1:])\n")
    out = _python("", "-m", "aamsim.compat.bluesky", str(script), "--episodes", "3")
    assert out == "aamsim.compat.bluesky ['--episodes', '3']"
