"""Plugin loader.

A plugin is a module with ``init_plugin(sim)``: it receives the simulation
and registers what it provides explicitly (``sim.commands.add(...)``,
``sim.hooks.post_step.add(...)``, ...), keeping any state in its own objects
(or in ``sim.features``, one object of its own class), never in module globals, so that two simulations in
one process stay independent. ``init_plugin`` may return an object; it is
kept in ``sim.plugins[name]``. ``docs/plugins.md`` shows how to write one.

Plugins come from the built-in table below or from installed packages that
declare an entry point in the ``aamsim.plugins`` group::

    [options.entry_points]
    aamsim.plugins =
        myplugin = mypackage.myplugin

From Python and the command line (``aamsim run --plugin``, ``aamsim serve
--plugin``) a plugin can also be named by its importable module path
(``mypackage.myplugin``), e.g. while developing it; the ``PLUGINS LOAD``
stack command loads registered plugins only, so that scenario files and
remote clients of the simulation server cannot import arbitrary modules.
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points
from types import ModuleType
from typing import TYPE_CHECKING, Any

from aamsim.errors import CommandError

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

BUILTIN_PLUGINS: dict[str, str] = {
    "EXAMPLE": "aamsim.plugins.example",
    "GEOVECTOR": "aamsim.plugins.geovector",  # BlueSky's geovector plugin
    "BRIDGE": "rlbridge.plugin",  # the RL bridge; provides serve() for `aamsim serve`
}


# Stack commands of the built-in plugins, so that a scenario that loads a plugin may use its
# commands further down (the file is parsed before PLUGINS LOAD runs).
PLUGIN_COMMANDS: dict[str, tuple[str, ...]] = {
    "GEOVECTOR": ("GEOVECTOR", "DELGEOVECTOR"),
}


def plugin_providing(command: str) -> str | None:
    """The built-in plugin that provides a stack command, or None."""
    name = command.upper()
    return next((plugin for plugin, names in PLUGIN_COMMANDS.items() if name in names), None)


def _entry_point_plugins() -> dict[str, Any]:
    return {ep.name.upper(): ep for ep in entry_points(group="aamsim.plugins")}


def available() -> dict[str, str]:
    """Name -> where it comes from (module path or distribution)."""
    found = {name: path for name, path in BUILTIN_PLUGINS.items()}
    for name, ep in _entry_point_plugins().items():
        found.setdefault(name, ep.value)
    return found


def _unknown(name: str) -> CommandError:
    return CommandError(f"unknown plugin {name}; available: {', '.join(sorted(available())) or 'none'}")


def _import(name: str, modules: bool = False) -> ModuleType:
    key = name.upper()
    if key in BUILTIN_PLUGINS:
        return importlib.import_module(BUILTIN_PLUGINS[key])
    eps = _entry_point_plugins()
    if key in eps:
        loaded = eps[key].load()
        if isinstance(loaded, ModuleType):
            return loaded
        module = importlib.import_module(loaded.__module__)
        return module
    if modules and name.replace(".", "").replace("_", "").isalnum():
        try:
            return importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name is None or not (name == exc.name or name.startswith(exc.name + ".")):
                raise  # the plugin exists but one of its own imports is missing
    raise _unknown(name)


def plugin_module(name: str, modules: bool = True) -> ModuleType:
    """The module of a plugin (registered name, or module path if ``modules``), imported but not loaded."""
    return _import(name, modules)


def load_plugin(sim: CommandContext, name: str, *, modules: bool = True) -> Any:
    """Load a plugin into a simulation (once); returns what ``init_plugin`` returned.

    ``name`` is a registered plugin name (built in or an entry point) or, when
    ``modules`` is true, an importable module path.
    """
    key = name.upper()
    if key in sim.plugins:
        return sim.plugins[key]
    module = _import(name, modules)
    init = getattr(module, "init_plugin", None)
    if init is None:
        raise CommandError(f"plugin {name} has no init_plugin(sim) function")
    result = init(sim)
    sim.plugins[key] = result if result is not None else module
    return sim.plugins[key]
