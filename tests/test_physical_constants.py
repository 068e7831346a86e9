"""Physical constants have one home, aamsim/units.py: no module writes the earth's radius again (issue 29)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EARTH_RADII_M = {6371000.0, 6371.0, 6378137.0, 6378.137}  # mean radius and WGS-84 semi-major axis, m and km
# The homes: units.py (R_EARTH) and geo.py (the WGS-84 ellipsoid); the BlueSky API shim repeats BlueSky's own
# module constants (bluesky.tools.aero.Rearth, ...) by name, as BlueSky's code reads them.
HOMES = {"aamsim/units.py", "aamsim/geo.py"}
SHIM = "aamsim/compat/"


def literal_radii(path: Path) -> list[int]:
    return [node.lineno for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, ast.Constant) and type(node.value) in (int, float)
            and float(node.value) in EARTH_RADII_M]


def test_the_earth_radius_is_written_only_in_its_home():
    found = {}
    for package in ("aamsim", "rlbridge", "uamtoolkit_import"):
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel in HOMES or rel.startswith(SHIM):
                continue
            lines = literal_radii(path)
            if lines:
                found[rel] = lines
    assert found == {}, "use aamsim.units.R_EARTH (or aamsim.geo's WGS-84 axes) instead"
