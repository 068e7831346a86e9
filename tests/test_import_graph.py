"""The import graph of ``aamsim`` has no cycle, counting the imports made only for type checking (issue 29).

import-linter's contracts (.importlinter) leave out ``if TYPE_CHECKING:`` imports; a type-only import of
the concrete ``Simulation`` from a handler that ``Simulation`` itself imports is still a circle in the
design (the handler knows the whole class). The graph is built here from the sources with ``ast``:
an edge from a module to each ``aamsim`` module it imports, wherever the import statement stands
(top level, a function, an ``if TYPE_CHECKING:`` block); ``from aamsim.x import name`` goes to the
module ``aamsim.x.name`` when there is one, else to ``aamsim.x``. Parent packages are not counted (as
import-linter does not): ``import aamsim.x.y`` is an edge to ``aamsim.x.y`` only.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ast_sources import import_statements, module_name, package_of, parse, python_files

ROOT = Path(__file__).resolve().parents[1]


def module_files(package_dir: Path) -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is a package's ``__init__``)."""
    return {name: (path, is_package) for path in python_files(package_dir)
            for name, is_package in [module_name(path, package_dir.parent)]}


def import_graph(package_dir: Path) -> dict[str, set[str]]:
    """Module -> the modules of the package it imports (every import statement, type-only ones included)."""
    files = module_files(package_dir)
    root = package_dir.name

    def known(name: str) -> str | None:
        while name and name not in files:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {name: set() for name in files}
    for name, (path, _) in files.items():
        for st in import_statements(parse(path), package_of(path, package_dir.parent)):
            if st.module.split(".")[0] != root:
                continue
            if st.from_import:
                targets = [known(f"{st.module}.{alias}") if f"{st.module}.{alias}" in files else known(st.module)
                           for alias in st.names]
            else:
                targets = [known(st.module)]
            graph[name].update(t for t in targets if t is not None and t != name)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), each sorted, largest first."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(graph) + 100))
    try:
        for v in sorted(graph):
            if v not in index:
                visit(v)
    finally:
        sys.setrecursionlimit(limit)
    return sorted(found, key=len, reverse=True)


def test_the_graph_builder_finds_type_only_cycles(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from pkg.sub.b import B\n")
    (pkg / "a.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.sub.b import B\n")
    (pkg / "sub" / "b.py").write_text("from .. import a\nB = 1\n")
    (pkg / "c.py").write_text("import pkg.a\n")
    graph = import_graph(pkg)
    assert graph == {"pkg": set(), "pkg.sub": {"pkg.sub.b"}, "pkg.a": {"pkg.sub.b"}, "pkg.sub.b": {"pkg.a"},
                     "pkg.c": {"pkg.a"}}
    assert cycles(graph) == [["pkg.a", "pkg.sub.b"]]


# Three cycles were broken to make this hold (issue 29): the 39 modules around the concrete Simulation (its
# services, the run-end check and the metric registry annotate against aamsim.simapi.SimulationCore, a
# Protocol in a leaf module, instead of importing aamsim.simulation; the command registry no longer imports
# aamsim.stack.context), aamsim.traffic (Traffic declares the BlockStorage protocol its pool satisfies) and
# aamsim.compat.bluesky (the array store declares the ArraySession it uses; the session is given the
# process's command stack instead of importing _state).
def test_the_aamsim_import_graph_has_no_cycle():
    assert cycles(import_graph(ROOT / "aamsim")) == []
