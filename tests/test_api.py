"""The public simulator API: read-only views, intents shared with the stack, field rows, import rule."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import aamsim
from aamsim import Simulation
from aamsim.traffic import fields
from aamsim.units import FPM, FT, KTS, Speed

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def two() -> Simulation:
    sim = Simulation(seed=0)
    sim.stack("CRE A EC35 40 -74 090 1000 100; CRE B EC35 40.1 -74 180 2000 80")
    return sim


def test_view_is_named_readonly_si(two):
    v = two.view
    assert v.ids == ("A", "B")
    assert v.lat.tolist() == [40.0, 40.1]
    assert v.alt[1] == pytest.approx(2000 * FT)
    assert v.cas[0] == pytest.approx(100 * KTS)
    with pytest.raises(ValueError):
        v.lat[0] = 1.0
    # No copy: the view sees the next step's state.
    lat = two.view.lat
    two.step()
    assert np.shares_memory(lat, two.view.lat)


def test_every_field_row_is_generated_from_its_name():
    for k, name in enumerate(fields.FLOAT_FIELDS):
        assert getattr(fields, name.upper()) == k
    for k, name in enumerate(fields.BOOL_FIELDS):
        assert getattr(fields, "B_" + name.upper()) == k


def test_select_speed_is_the_same_intent_as_spd(two):
    other = Simulation(seed=0)
    other.stack("CRE A EC35 40 -74 090 1000 100; CRE B EC35 40.1 -74 180 2000 80")
    two.select_speed("A", 60 * KTS)
    other.stack("SPD A 60")
    for sim in (two, other):
        sim.run_until(30.0)
    assert two.view.cas.tolist() == other.view.cas.tolist()
    assert two.view.selspd[0] == pytest.approx(60 * KTS) and not two.view.vnav_speed[0]


def test_vectorised_speed_and_hold(two):
    two.select_speed(np.array([0, 1]), np.array([10.0, 20.0]))
    assert two.view.selspd.tolist() == [10.0, 20.0]
    two.hold_speed(["B"])
    assert two.view.selspd[1] == pytest.approx(80 * KTS)
    two.select_speed("A", Speed(0.3, is_mach=True))
    assert two.view.selspd_mach[0] and two.view.selspd[0] == pytest.approx(0.3)


def test_altitude_heading_vs_intents_match_stack(two):
    other = Simulation(seed=0)
    other.stack("CRE A EC35 40 -74 090 1000 100; CRE B EC35 40.1 -74 180 2000 80")
    two.select_altitude("A", 1500 * FT, 500 * FPM)
    two.select_heading("B", 45.0)
    other.stack("ALT A 1500 500; HDG B 45")
    for sim in (two, other):
        sim.run_until(20.0)
    assert two.view.alt.tolist() == other.view.alt.tolist()
    assert two.view.hdg.tolist() == other.view.hdg.tolist()
    assert not two.view.lnav[1]


def test_create_delete_direct_to(two):
    slot = two.create("C", "EC35", 40.2, -74.0, 0.0, 300.0, 20.0)
    assert two.view.ids[slot] == "C" and two.view.alt[slot] == 300.0
    two.stack("ADDWPT C 40.3 -74.0; ADDWPT C 40.4 -74.0")
    two.direct_to("C", 1)
    route = two.view.route(two.slot("C"))
    assert route.iactwp == 1 and two.view.lnav[two.slot("C")]
    with pytest.raises(Exception, match="no waypoint"):
        two.direct_to("C", "NOPE")
    two.delete(["A", "C"])
    assert two.view.ids == ("B",)


def test_public_api_is_exported():
    assert aamsim.TrafficView is not None and callable(aamsim.Simulation.select_speed)


def _imports_of(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
            out.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_no_module_outside_traffic_imports_the_field_rows():
    offenders = []
    for pkg in ("aamsim", "rlbridge", "uamtoolkit_import"):
        for path in (ROOT / pkg).rglob("*.py"):
            if path.parent == ROOT / "aamsim" / "traffic":
                continue
            if "aamsim.traffic.fields" in _imports_of(path):
                offenders.append(str(path.relative_to(ROOT)))
    assert offenders == []


def test_import_layers_contract():
    """``lint-imports`` (import-linter) keeps the layers of .importlinter: bridge -> stack -> services ->
    metrics -> conflicts -> traffic, never backwards."""
    import os
    import shutil
    import subprocess

    exe = shutil.which("lint-imports")
    if exe is None:
        pytest.skip("import-linter is not installed (pip install 'aamsim[test]')")
    env = dict(os.environ, PYTHONPATH=str(ROOT))  # this checkout's packages, not an installed copy
    proc = subprocess.run([exe], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "1 kept, 0 broken" in proc.stdout
