"""The use cases sit below the agents and the experiment layer: they import neither.

Read from the source files (every ``import``, at module level, inside functions
and under ``TYPE_CHECKING``, and ``importlib.import_module`` calls with a literal
name), so a circle through a function-level import counts too. Frozen policies
reach the use cases injected (rlbridge.usecases.frozen.PolicySource).
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = ("rlbridge.experiment", "rlbridge.agents")


def imported_modules(path: Path, root: Path = ROOT) -> list[tuple[int, str]]:
    """``(line, module)`` of every import in a source file (relative imports resolved in the package)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    package = ".".join(path.relative_to(root).with_suffix("").parts[:-1])
    out: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.extend((node.lineno, alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            out.append((node.lineno, base))
            out.extend((node.lineno, f"{base}.{alias.name}") for alias in node.names)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", None)) \
                == "import_module" and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str):
            out.append((node.lineno, node.args[0].value))
    return out


def violations(folder: Path, forbidden: tuple[str, ...], root: Path = ROOT) -> list[str]:
    """``file:line imports module`` for every import of a ``forbidden`` package under ``folder``."""
    found = []
    for path in sorted(folder.rglob("*.py")):
        for line, module in imported_modules(path, root):
            if any(module == f or module.startswith(f + ".") for f in forbidden):
                found.append(f"{path.relative_to(root)}:{line} imports {module}")
    return sorted(set(found))


def test_usecases_never_import_the_experiment_layer_or_the_agents():
    assert violations(ROOT / "rlbridge" / "usecases", FORBIDDEN) == []


def test_the_contract_sees_function_level_type_checking_and_relative_imports(tmp_path):
    pkg = tmp_path / "rlbridge" / "usecases"
    pkg.mkdir(parents=True)
    (pkg / "a.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                              "    from rlbridge.core import EpisodeCore\n    import rlbridge.agents.ddqn\n")
    (pkg / "b.py").write_text("def f():\n    from ..experiment.train import load_checkpoint\n")
    (pkg / "c.py").write_text("import importlib\nm = importlib.import_module('rlbridge.agents')\n")
    (pkg / "d.py").write_text("from rlbridge.agents_extra import x\nfrom rlbridge import usecases\n")
    assert violations(pkg, FORBIDDEN, tmp_path) == [
        "rlbridge/usecases/a.py:4 imports rlbridge.agents.ddqn",
        "rlbridge/usecases/b.py:2 imports rlbridge.experiment.train",
        "rlbridge/usecases/b.py:2 imports rlbridge.experiment.train.load_checkpoint",
        "rlbridge/usecases/c.py:2 imports rlbridge.agents",
    ]


def world_reads(folder: Path, root: Path = ROOT) -> list[str]:
    """``file:line`` of every read of an object's ``traffic`` / ``_traffic`` attribute under ``folder``.

    The simulation's world (its traffic arrays) is aamsim's: rlbridge reads the traffic through the
    simulation API (``sim.view``, ``sim.slots``, the snapshot) and changes it through its intents.
    Module paths (``aamsim.traffic.view``) are not reads of the world and are left out.
    """
    found = []
    for path in sorted(folder.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Attribute) and node.attr in ("traffic", "_traffic"):
                base = node.value
                while isinstance(base, ast.Attribute):
                    base = base.value
                if isinstance(base, ast.Name) and base.id == "aamsim":
                    continue
                found.append(f"{path.relative_to(root)}:{node.lineno}")
    return found


def test_rlbridge_never_reads_the_simulations_world():
    assert world_reads(ROOT / "rlbridge") == []


def test_the_world_check_sees_reads_and_writes_but_not_module_paths(tmp_path):
    pkg = tmp_path / "rlbridge"
    pkg.mkdir()
    (pkg / "a.py").write_text("import aamsim.traffic.view\nfrom aamsim.traffic import fields\n"
                              "def f(sim):\n    n = sim.traffic.n\n    sim.core.sim._traffic.F[0] = 1\n"
                              "    return aamsim.traffic.view.PUBLIC_FLOATS\n")
    assert world_reads(pkg, tmp_path) == ["rlbridge/a.py:4", "rlbridge/a.py:5"]
