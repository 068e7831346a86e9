"""``install()``: make ``import bluesky`` give :mod:`aamsim.compat.bluesky` in this process.

A meta-path finder, first on ``sys.meta_path``, answers for ``bluesky`` and its
submodules: the modules the shim provides are the shim's own module objects
(``sys.modules['bluesky'] is sys.modules['aamsim.compat.bluesky']``), any other
``bluesky.x`` raises :class:`~aamsim.compat.bluesky._errors.NotProvidedModule`.
Without ``install()`` nothing changes: ``import bluesky`` finds the real BlueSky
if it is installed, and the shim is still importable as ``aamsim.compat.bluesky``.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
from types import ModuleType

from aamsim.compat.bluesky._errors import not_provided_module

SHIM = "aamsim.compat.bluesky"
# BlueSky's module -> the shim's module that stands in for it.
PROVIDED = {
    "bluesky": SHIM,
    "bluesky.settings": f"{SHIM}.settings",
    "bluesky.stack": f"{SHIM}.stack",
    "bluesky.simulation": f"{SHIM}.simulation",
    "bluesky.tools": f"{SHIM}.tools",
    "bluesky.tools.geo": f"{SHIM}.tools.geo",
    "bluesky.tools.aero": f"{SHIM}.tools.aero",
    "bluesky.tools.areafilter": f"{SHIM}.tools.areafilter",
}


class _Alias(importlib.abc.Loader):
    """Loads a BlueSky module name as an already imported shim module."""

    def __init__(self, module: ModuleType) -> None:
        self.module = module

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        return self.module

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the shim module is imported already."""


class BlueSkyFinder(importlib.abc.MetaPathFinder):
    """Finds ``bluesky`` and ``bluesky.*`` in the shim (see the module docstring)."""

    def find_spec(self, fullname: str, path: object = None, target: object = None) -> importlib.machinery.ModuleSpec | None:
        if fullname != "bluesky" and not fullname.startswith("bluesky."):
            return None
        shim_name = PROVIDED.get(fullname)
        if shim_name is None:
            raise not_provided_module(fullname)
        module = importlib.import_module(shim_name)
        return importlib.util.spec_from_loader(fullname, _Alias(module), is_package=hasattr(module, "__path__"))


def _finder() -> BlueSkyFinder | None:
    return next((f for f in sys.meta_path if isinstance(f, BlueSkyFinder)), None)


def installed() -> bool:
    """Whether ``import bluesky`` gives the shim in this process."""
    return _finder() is not None


def install() -> None:
    """Make ``import bluesky`` (and the submodules the shim provides) give the shim in this process.

    Raises:
        RuntimeError: the real BlueSky is imported in this process already (both cannot be
            ``bluesky`` at once; run the code in another process, or import the shim as
            ``aamsim.compat.bluesky``).
    """
    if installed():
        return
    real = sys.modules.get("bluesky")
    if real is not None and real is not sys.modules.get(SHIM):
        raise RuntimeError("the real BlueSky is imported in this process already: aamsim.compat.bluesky.install() "
                           "must run before the first `import bluesky` (or use aamsim.compat.bluesky directly)")
    sys.meta_path.insert(0, BlueSkyFinder())


def uninstall() -> None:
    """Undo :func:`install`: ``import bluesky`` finds the real BlueSky again (the shim stays importable)."""
    finder = _finder()
    if finder is not None:
        sys.meta_path.remove(finder)
    for name in [n for n in sys.modules if n == "bluesky" or n.startswith("bluesky.")]:
        if PROVIDED.get(name) and sys.modules[name] is sys.modules.get(PROVIDED[name]):
            del sys.modules[name]
