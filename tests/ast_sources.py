"""Read Python sources with ``ast``: the one walker that the import contract and the import-graph test share.

Both tests read the source files, not the imported modules, so that every import counts wherever it
stands (top level, inside a function, under ``if TYPE_CHECKING:``) and nothing is executed.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class ImportStatement:
    """One import found in a source file, relative imports resolved.

    ``module`` is the imported module (``import a.b``, ``importlib.import_module("a.b")``) or, for
    ``from a.b import x, y``, the module the names come from (``names`` then holds ``x`` and ``y``).
    """

    line: int
    module: str
    names: tuple[str, ...] = ()
    from_import: bool = False
    dynamic: bool = False  # an ``import_module`` call with a literal name


def python_files(folder: Path) -> list[Path]:
    """Every ``*.py`` file under ``folder``, sorted (deterministic reports)."""
    return sorted(folder.rglob("*.py"))


def parse(path: Path) -> ast.Module:
    """The syntax tree of a source file (its path in syntax errors)."""
    return ast.parse(path.read_text(encoding="utf-8"), str(path))


def module_name(path: Path, root: Path) -> tuple[str, bool]:
    """Dotted module name of ``path`` relative to ``root`` and whether it is a package's ``__init__``."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        return ".".join(parts[:-1]), True
    return ".".join(parts), False


def package_of(path: Path, root: Path) -> str:
    """The package a relative import in ``path`` starts from (the package itself for an ``__init__``)."""
    name, is_package = module_name(path, root)
    return name if is_package else name.rpartition(".")[0]


def resolve(module: str | None, level: int, package: str) -> str:
    """Absolute name of ``from <level dots><module> import ...`` written in ``package``."""
    if not level:
        return module or ""
    parts = package.split(".")
    parts = parts[:len(parts) - level + 1]
    return ".".join(parts + ([module] if module else []))


def import_statements(tree: ast.AST, package: str) -> Iterator[ImportStatement]:
    """Every import in ``tree`` (one per ``import`` alias), in the order ``ast.walk`` finds them."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield ImportStatement(node.lineno, alias.name)
        elif isinstance(node, ast.ImportFrom):
            yield ImportStatement(node.lineno, resolve(node.module, node.level, package),
                                  tuple(alias.name for alias in node.names), from_import=True)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", None)) \
                == "import_module" and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str):
            yield ImportStatement(node.lineno, node.args[0].value, dynamic=True)


def attribute_reads(tree: ast.AST, attrs: frozenset[str], module_roots: frozenset[str] = frozenset()
                    ) -> Iterator[tuple[int, str]]:
    """``(line, attr)`` of every ``x.attr`` (read or written) with ``attr`` in ``attrs``.

    Dotted module paths that start with a name in ``module_roots`` (``aamsim.traffic.view``) are
    not attribute reads of an object and are left out.
    """
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr in attrs:
            base = node.value
            while isinstance(base, ast.Attribute):
                base = base.value
            if isinstance(base, ast.Name) and base.id in module_roots:
                continue
            yield node.lineno, node.attr
