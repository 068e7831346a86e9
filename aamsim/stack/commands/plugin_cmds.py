"""PLUGINS LIST / LOAD, as in BlueSky."""

from __future__ import annotations

from typing import TYPE_CHECKING

from aamsim.errors import CommandError
from aamsim.stack.argtypes import Text
from aamsim.stack.registry import command

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext


@command("PLUGINS", aliases=("PLUGIN", "PLUG-IN", "PLUG-INS"), group="simulation")
def plugins(sim: CommandContext, action: Text = "LIST", name: Text = "") -> str | None:
    """PLUGINS [LIST | LOAD name | name]: list the available plugins or load one."""
    from aamsim import plugins as loader

    if action == "LIST":
        names = sorted(loader.available())
        loaded = sorted(sim.plugins)
        return f"available plugins: {', '.join(names) or '-'}\nloaded: {', '.join(loaded) or '-'}"
    if action in ("LOAD", "ENABLE") or not name:
        # As BlueSky: PLUGIN name (no action word) loads the plugin too.
        name = name or action
        if name in ("LOAD", "ENABLE"):
            raise CommandError("PLUGINS LOAD needs a plugin name")
        loader.load_plugin(sim, name, modules=False)  # registered plugins only
        return f"plugin {name} loaded"
    raise CommandError(f"PLUGINS {action}: use LIST or LOAD name")


COMMANDS = (plugins,)
