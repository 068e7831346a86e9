"""The use cases sit below the agents and the experiment layer: they import neither.

Read from the source files (every ``import``, at module level, inside functions
and under ``TYPE_CHECKING``, and ``importlib.import_module`` calls with a literal
name), so a circle through a function-level import counts too. Frozen policies
reach the use cases injected (rlbridge.usecases.frozen.PolicySource).
"""

from __future__ import annotations

from pathlib import Path

from ast_sources import attribute_reads, import_statements, package_of, parse, python_files

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = ("rlbridge.experiment", "rlbridge.agents")


def imported_modules(path: Path, root: Path = ROOT) -> list[tuple[int, str]]:
    """``(line, module)`` of every import in a source file (relative imports resolved in the package).

    ``from a import b`` counts as an import of ``a`` and of ``a.b`` (``b`` may be a module).
    """
    out: list[tuple[int, str]] = []
    for st in import_statements(parse(path), package_of(path, root)):
        out.append((st.line, st.module))
        out.extend((st.line, f"{st.module}.{name}") for name in st.names)
    return out


def violations(folder: Path, forbidden: tuple[str, ...], root: Path = ROOT) -> list[str]:
    """``file:line imports module`` for every import of a ``forbidden`` package under ``folder``."""
    found = []
    for path in python_files(folder):
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


# The modules that implement the engine and may touch the simulation's world (its private ``_traffic``):
# the traffic package, the simulation and its API, the service protocol, worlds stepped together, the
# stack's command context, the built-in services and the BlueSky compatibility layer (BlueSky's ``traf``
# is implemented on the engine's arrays). Paths relative to the repository, a trailing "/" for a folder.
ENGINE = ("aamsim/traffic/", "aamsim/simulation.py", "aamsim/api.py", "aamsim/simapi.py", "aamsim/worlds.py",
          "aamsim/stack/context.py", "aamsim/services.py", "aamsim/snapshots.py", "aamsim/conflicts/",
          "aamsim/metrics/", "aamsim/resolution/", "aamsim/compat/bluesky/")
WORLD = frozenset({"traffic", "_traffic"})
MODULE_ROOTS = frozenset({"aamsim", "bluesky"})  # aamsim.traffic.view, bluesky.traffic.performance: modules


def world_reads(folder: Path, root: Path = ROOT, attrs: frozenset[str] = WORLD,
                exempt: tuple[str, ...] = ()) -> list[str]:
    """``file:line`` of every read (or write) of an object's ``traffic`` / ``_traffic`` attribute under ``folder``.

    The simulation's world (its traffic arrays) is the engine's: everything else reads the traffic through
    the simulation API (``sim.view``, ``sim.slots``, the snapshot) and changes it through its intents.
    Module paths (``aamsim.traffic.view``) are not reads of the world and are left out; so are the files
    whose path relative to ``root`` starts with one of ``exempt``.
    """
    found = []
    for path in python_files(folder):
        rel = path.relative_to(root).as_posix()
        if rel.startswith(exempt):
            continue
        found.extend(f"{rel}:{line}" for line, _ in attribute_reads(parse(path), attrs, MODULE_ROOTS))
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


def test_only_the_engine_reads_the_simulations_world():
    # Simulation.traffic became Simulation._traffic (issue 29): the CLI, the runner, the run-end check, the
    # viewer and the rest of aamsim read the traffic through sim.view like any user of the API.
    assert world_reads(ROOT / "aamsim", exempt=ENGINE) == []


def test_tests_bench_and_scripts_never_read_a_public_world():
    # There is no public Simulation.traffic any more; a test or a bench script that inspects the engine's
    # arrays says so by naming the private sim._traffic, everything else uses the public API.
    found = [read for folder in ("tests", "bench", "scripts", "examples")
             for read in world_reads(ROOT / folder, attrs=frozenset({"traffic"}))]
    assert found == []


def test_the_world_check_exempts_only_the_engine(tmp_path):
    eng = tmp_path / "aamsim" / "traffic"
    eng.mkdir(parents=True)
    (eng / "kernel.py").write_text("def f(sim):\n    return sim._traffic.n + sim.traffic.n\n")
    (tmp_path / "aamsim" / "cli.py").write_text("import bluesky.traffic.performance\n"
                                                "def g(sim):\n    return sim.view.n, sim._traffic.n\n")
    assert world_reads(tmp_path / "aamsim", tmp_path, exempt=("aamsim/traffic/",)) == ["aamsim/cli.py:3"]
    assert world_reads(tmp_path / "aamsim", tmp_path, attrs=frozenset({"traffic"})) == ["aamsim/traffic/kernel.py:2"]
