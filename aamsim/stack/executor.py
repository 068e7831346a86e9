"""Running stack commands: parse, bind the arguments, call the handler, report what went wrong.

:class:`CommandExecutor` is the stack of one simulation. It runs command text
now (:meth:`stack`), queues it for later (:meth:`schedule`), and remembers
which command is running (so a handler that schedules more can cite it) and
the last command that touched each aircraft (so an aircraft whose state goes
wrong can be traced to a scenario line). Handlers receive the simulation as a
:class:`~aamsim.stack.context.CommandContext`.
"""

from __future__ import annotations

from collections.abc import Callable

from aamsim.errors import ArgumentError, CommandError, ScenarioSyntaxError, SourceRef
from aamsim.stack.argtypes import ACID
from aamsim.stack.context import CommandContext, LiveContext
from aamsim.stack.parser import Command, TimedCommand, parse_line, resolve_command_form, split_commands
from aamsim.stack.queue import CommandQueue
from aamsim.stack.registry import CommandRegistry

Report = Callable[[str, str, "SourceRef | None"], None]


class CommandExecutor:
    """The command stack of one simulation (see the module's docstring)."""

    def __init__(self, ctx: CommandContext, registry: CommandRegistry, queue: CommandQueue, report: Report):
        self.ctx = ctx
        self.registry = registry
        self.queue = queue
        self.report = report
        self.source: SourceRef | None = None  # of the command being executed
        self.command_text = ""  # the command being executed
        self.last_command: dict[str, tuple[str, SourceRef | None]] = {}  # callsign -> last command on it

    def stack(self, text: str, source: SourceRef | None = None) -> bool:
        """Execute command text now (``;`` separates commands). True if all succeeded."""
        ok = True
        for part in split_commands(text):
            try:
                command = parse_line(part, source)
            except ScenarioSyntaxError as exc:
                self.report("error", exc.message, source)
                ok = False
                continue
            ok = self.execute(command, source) and ok
        return ok

    def schedule(self, time_s: float, text: str, source: SourceRef | None = None) -> None:
        """Queue command text for a sim time [s]."""
        for part in split_commands(text):
            try:
                command = parse_line(part, source)
            except ScenarioSyntaxError as exc:
                self.report("error", exc.message, source)
                continue
            self.queue.push(TimedCommand(time_s, command, source or SourceRef()))

    def execute(self, command: Command, source: SourceRef | None = None) -> bool:
        """Run one command through the command table; report any error."""
        registry = self.registry
        command = resolve_command_form(command, registry.__contains__)
        spec = registry.get(command.name)
        ctx = self.ctx
        if spec is None and not command.argtext and (command.name in ctx.view or ctx.navdb.known(command.name)):
            # A bare callsign or waypoint name is a position query, as in BlueSky.
            command = Command("POS", command.name)
            spec = registry.get("POS")
        if spec is None:
            from aamsim.plugins import plugin_providing

            plugin = plugin_providing(command.name)
            hint = f" (the {plugin} plugin provides it: PLUGINS LOAD {plugin})" if plugin else ""
            self.report("error", f"unknown command {command.name}{hint}", source)
            return False
        try:
            args = spec.bind(command.argtext, LiveContext(ctx))
            self.source = source
            self.command_text = str(command)
            if args and spec.params and spec.params[0].argtype is ACID and isinstance(args[0], int):
                self.last_command[ctx.view.callsign(args[0])] = (self.command_text, source)
            result = spec.handler(ctx, *args)
        except (ArgumentError, CommandError) as exc:
            self.report("error", f"{command.name}: {exc.message}", source)
            return False
        if isinstance(result, str) and result:
            self.report("echo", result, source)
        return True
