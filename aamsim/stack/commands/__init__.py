"""Built-in stack commands, registered per simulation by :func:`register_builtin_commands`."""

from __future__ import annotations

from aamsim.stack.commands import (
    area_cmds,
    asas_cmds,
    compat_cmds,
    daa_cmds,
    display_cmds,
    plugin_cmds,
    realtraffic_cmds,
    reso_cmds,
    route_cmds,
    sim_cmds,
    traffic_cmds,
    wind_cmds,
)
from aamsim.stack.registry import CommandRegistry

MODULES = (traffic_cmds, route_cmds, sim_cmds, asas_cmds, daa_cmds, plugin_cmds, area_cmds, compat_cmds,
           display_cmds, wind_cmds, realtraffic_cmds, reso_cmds)


def register_builtin_commands(registry: CommandRegistry) -> None:
    for module in MODULES:
        registry.add_all(module.COMMANDS)
