"""The classifiers' proof: the wheel, installed in a fresh environment per Python, runs the main job alike.

    python scripts/smoke_pythons.py                         # python3.11, python3.12, python3.13 where present
    python scripts/smoke_pythons.py --wheel dist/aamsim-0.1.0-py3-none-any.whl python3.12

Builds the wheel (``python -m build --wheel``) unless one is given. For each interpreter found
on the PATH: a virtual environment in a temporary folder, the wheel installed into it (the base
install), ``aamsim run scn/nyc_day.scn --until 600`` run from an empty folder, and the SHA-256
of the outputs that do not depend on the machine (``flights.csv``, ``conflicts.csv``,
``trajectories.csv``, ``scenario.scn``). Prints one row per interpreter; exits 1 if one fails
or its outputs differ from the first one's. An interpreter is looked for on the PATH, then among
pyenv's installed versions; one that is not on this machine is listed as absent.
``.ci/run`` runs it after the test suite.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUTPUTS = ("flights.csv", "conflicts.csv", "trajectories.csv", "scenario.scn")
DEFAULT = ("python3.11", "python3.12", "python3.13")


def find_python(name: str) -> str | None:
    """An interpreter that runs: ``name`` on the PATH, else a pyenv installation of that version.

    (pyenv's shims are on the PATH for every version but run only the versions enabled.)
    """
    candidates = [shutil.which(name)]
    if name.startswith("python3."):
        root = Path(os.environ.get("PYENV_ROOT", Path.home() / ".pyenv"))
        candidates += [str(p) for p in sorted(root.glob(f"versions/{name[6:]}*/bin/{name}"), reverse=True)]
    for exe in candidates:
        if exe and subprocess.run([exe, "-c", "pass"], capture_output=True, check=False).returncode == 0:
            return exe
    return None


def build_wheel(out: Path) -> Path:
    subprocess.run([sys.executable, "-m", "build", "--wheel", "--outdir", str(out), str(ROOT)], check=True,
                   capture_output=True, text=True)
    return next(out.glob("aamsim-*.whl"))


def smoke(python: str, wheel: Path, work: Path) -> dict[str, str]:
    """Install ``wheel`` with ``python`` into a fresh venv under ``work``; the main job's output hashes."""
    subprocess.run([python, "-m", "venv", str(work / "venv")], check=True, capture_output=True, text=True)
    subprocess.run([str(work / "venv" / "bin" / "python"), "-m", "pip", "install", "--quiet", str(wheel)],
                   check=True, capture_output=True, text=True)
    user = work / "user"
    user.mkdir()
    subprocess.run([str(work / "venv" / "bin" / "aamsim"), "run", "scn/nyc_day.scn", "--until", "600", "--out",
                    "run", "--quiet"], cwd=user, check=True, capture_output=True, text=True)
    return {name: hashlib.sha256((user / "run" / name).read_bytes()).hexdigest() for name in OUTPUTS}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("pythons", nargs="*", default=list(DEFAULT))
    ap.add_argument("--wheel", type=Path, default=None)
    args = ap.parse_args(argv)
    status, first = 0, None
    with tempfile.TemporaryDirectory(prefix="aamsim-smoke-") as tmp:
        wheel = args.wheel or build_wheel(Path(tmp) / "dist")
        print(f"wheel: {wheel.name}")
        for python in args.pythons:
            exe = find_python(python)
            if exe is None:
                print(f"{python:12s} absent on this machine")
                continue
            version = subprocess.run([exe, "-c", "import platform; print(platform.python_version())"],
                                     capture_output=True, text=True, check=True).stdout.strip()
            t0 = time.perf_counter()
            try:
                hashes = smoke(exe, wheel, Path(tmp) / python)
            except subprocess.CalledProcessError as exc:
                print(f"{python:12s} {version:8s} FAILED: {' '.join(map(str, exc.cmd))[:120]}\n{exc.stderr[-2000:]}")
                status = 1
                continue
            first = first or hashes
            same = "outputs identical to the first" if hashes == first else "OUTPUTS DIFFER from the first"
            status |= hashes != first
            print(f"{python:12s} {version:8s} ok in {time.perf_counter() - t0:5.0f} s; trajectories.csv "
                  f"{hashes['trajectories.csv'][:12]}; {same}")
    return status


if __name__ == "__main__":
    sys.exit(main())
