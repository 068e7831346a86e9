"""The compiled-code cache is keyed by the source: an edited module never runs stale machine code."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from aamsim.numba_cache import package_roots, source_digest

ROOT = Path(__file__).resolve().parents[1]


def test_digest_changes_with_any_source_file(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "b.py").write_text("y = 2\n")
    first = source_digest([pkg])
    assert source_digest([pkg]) == first  # deterministic
    (pkg / "sub" / "b.py").write_text("y = 3\n")
    second = source_digest([pkg])
    assert second != first
    (pkg / "sub" / "b.py").rename(pkg / "sub" / "c.py")  # same content, other name
    assert source_digest([pkg]) != second


def test_the_bluesky_api_shim_keeps_the_cache_and_has_no_compiled_code(tmp_path):
    """aamsim/compat is left out of the digest: it must hold no Numba code (nothing compiled reads it)."""
    pkg = tmp_path / "aamsim"
    (pkg / "compat" / "bluesky").mkdir(parents=True)
    (pkg / "kernel.py").write_text("x = 1\n")
    (pkg / "compat" / "bluesky" / "shim.py").write_text("y = 2\n")
    first = source_digest([pkg])
    (pkg / "compat" / "bluesky" / "shim.py").write_text("y = 3\n")
    assert source_digest([pkg]) == first
    (pkg / "kernel.py").write_text("x = 2\n")
    assert source_digest([pkg]) != first
    for path in (ROOT / "aamsim" / "compat").rglob("*.py"):
        assert "numba" not in path.read_text(), path


def test_package_roots_cover_the_packages():
    names = {p.name for p in package_roots()}
    assert {"aamsim", "rlbridge", "uamtoolkit_import"} <= names


def test_cache_directory_follows_the_source_and_respects_the_user(tmp_path):
    # The directory is chosen at the first compilation (here a load or compile of cas2tas_scalar).
    code = ("import aamsim, os, numba; from aamsim import aero; aero.cas2tas_scalar(50.0, 0.0); print("
            "os.environ['NUMBA_CACHE_DIR'] + '|' + str(numba.config.CACHE_DIR))")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(ROOT), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    chosen, configured = out.strip().split("|")
    assert chosen == configured
    assert Path(chosen).parent == tmp_path / "xdg" / "aamsim" / "numba"
    assert Path(chosen).name == source_digest(package_roots())
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "mine")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    assert out.strip() == f"{tmp_path / 'mine'}|{tmp_path / 'mine'}"


_WATCH_IMPORT = """
import json, os, sys
import numpy, numba, numba.np.linalg  # dependencies: what their own imports do is theirs
events = []
def hook(event, args):
    if event in ("os.mkdir", "os.rmdir", "os.remove", "shutil.rmtree", "os.putenv", "os.unsetenv"):
        events.append([event, str(args[0])])
    elif event == "open" and isinstance(args[0], str) and args[1] == "rb" and args[0].endswith(".py"):
        events.append([event, args[0]])  # a source read as bytes (the digest; imports use open_code, mode 'r')
sys.addaudithook(hook)
before = dict(os.environ)
ensure_blas = numba.np.linalg.ensure_blas
import aamsim, aamsim.numba_cache
print(json.dumps({
    "events": events,
    "environ_changed": dict(os.environ) != before,
    "numba_cache_dir": str(numba.config.CACHE_DIR),
    "blas_probe_patched": numba.np.linalg.ensure_blas is not ensure_blas or "numba.np.arraymath" in sys.modules,
}))
"""


def test_import_does_no_work(tmp_path):
    """``import aamsim`` hashes no source, creates or removes no directory, sets no environment variable
    and leaves Numba as it was: that work waits for the first compilation (issue 29)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(ROOT), XDG_CACHE_HOME=str(tmp_path / "xdg"), PYTHONDONTWRITEBYTECODE="1")
    out = subprocess.run([sys.executable, "-c", _WATCH_IMPORT], capture_output=True, text=True, env=env, check=True)
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    assert seen == {"events": [], "environ_changed": False, "numba_cache_dir": "", "blas_probe_patched": False}
    assert not (tmp_path / "xdg").exists()


def test_a_second_process_loads_the_compiled_code_from_the_cache(tmp_path):
    """The cache chosen at the first compilation is the one the next process loads from: no compilation."""
    code = ("from aamsim import aero; aero.cas2tas_scalar(50.0, 0.0); "
            "s = aero.cas2tas_scalar.stats; print(sum(s.cache_hits.values()), sum(s.cache_misses.values()))")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(ROOT), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                           check=True).stdout.split() for _ in range(2)]
    assert runs == [["0", "1"], ["1", "0"]]
    assert [p.name for p in (tmp_path / "xdg" / "aamsim" / "numba").iterdir()] == [source_digest(package_roots())]


def test_checkouts_sharing_the_cache_keep_each_others_directories(tmp_path, monkeypatch) -> None:
    # Ten checkouts of different sources used in turn: none may lose its compiled code to another's
    # pruning (with three kept, every run of every checkout compiled everything again).
    import os
    import time

    from aamsim import numba_cache

    base = tmp_path / "numba"
    base.mkdir()
    dirs = [base / f"src{k}" for k in range(10)]
    for d in dirs:
        d.mkdir()
        numba_cache._prune(base, d)
    assert all(d.is_dir() for d in dirs)
    stale = dirs[0]
    old = time.time() - (numba_cache._KEEP_DAYS + 1) * 86400
    os.utime(stale, (old, old))
    numba_cache._prune(base, dirs[1])
    assert not stale.exists() and all(d.is_dir() for d in dirs[1:])


def test_loading_compiled_code_does_not_import_scipy_and_blas_still_works():
    """Numba's start-up BLAS probe is answered without importing SciPy (0.2-0.3 s a process); the
    answer is the same, and np.dot in freshly compiled code still goes to SciPy's BLAS."""
    code = (
        "import sys, numpy as np\n"
        "from aamsim import aero\n"
        "aero.cas2tas_scalar(50.0, 100.0)\n"  # loads compiled code: Numba's target context starts
        "from numba.np import arraymath, linalg\n"
        "import importlib.util\n"
        "print('scipy.linalg' in sys.modules, arraymath._HAVE_BLAS, importlib.util.find_spec('scipy') is not None,"
        " arraymath.ensure_blas is linalg.ensure_blas)\n"
        "from numba import njit\n"
        "dot = njit(lambda a, b: np.dot(a, b))\n"
        "print(dot(np.arange(3.0), np.arange(3.0)), 'scipy.linalg' in sys.modules)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    first, second = out.stdout.strip().splitlines()
    assert first == "False True True True"
    assert second == "5.0 True"


def test_loaded_code_runs_without_numbas_registries_and_compiling_after_it_still_works(tmp_path):
    """Machine code from the cache is loaded without installing all of Numba's implementations (0.2 s a
    process); the code still allocates arrays (the runtime's symbols: without them it segfaulted), and a
    function compiled later in the same process gets the implementations it needs (a typed dict here)."""
    code = (
        "import sys, numpy as np\n"
        "from aamsim.output.fastcsv import format_rows, pack_names\n"
        "names, offsets = pack_names(['UAM1', 'UAM2'])\n"
        "rows = format_rows(names, offsets, np.array([1, 0]), np.array([[1.25, -0.5]]), np.array([1]))\n"
        "print(bytes(rows).decode().replace(chr(10), ';'), 'numba.typed.typeddict' in sys.modules,\n"
        "      sum(format_rows.__globals__['_format_rows_fast'].stats.cache_hits.values()))\n"
        "from numba import njit\n"
        "squares = njit(lambda n: {k: float(k * k) for k in range(n)})\n"
        "print(squares(4)[3], 'numba.typed.typeddict' in sys.modules)\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(ROOT), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
            for _ in range(2)]
    compiled, loaded = (run.stdout.strip().splitlines() for run in runs)
    assert compiled[0] == "UAM2,1.3;UAM1,-0.5; True 0"  # compiling installs everything (round half away)
    assert loaded[0] == "UAM2,1.3;UAM1,-0.5; False 1"  # loaded: the same rows, no registries
    assert compiled[1] == loaded[1] == "9.0 True"
