"""Static validation of a scenario file (``aamsim run --strict``).

Every line is parsed and every argument checked against its type without
simulating: callsigns must be created somewhere in the file (CRE), named
waypoints defined (DEFWPT) or known to the navigation data, units must read,
PCALLed files must exist, and command lines nested in ATALT / SCHEDULE / AT
... DO are checked as commands. All errors are returned at once.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from aamsim.errors import AamsimError, ArgumentError, CommandError, ScenarioSyntaxError, SourceRef
from aamsim.stack.context import StaticContext
from aamsim.stack.parser import Command, parse_line, parse_scenario, resolve_command_form
from aamsim.stack.registry import CommandRegistry
from aamsim.stack.tokens import next_arg


@dataclass
class _Checker(StaticContext):
    registry: CommandRegistry = field(default_factory=CommandRegistry)
    file_finder: Callable[[str], Path | None] | None = None
    depth: int = 0  # of nested command lines being checked

    def find_file(self, name: str) -> Path | None:
        return self.file_finder(name) if self.file_finder else None

    def check(self, command: Command) -> None:
        command = resolve_command_form(command, lambda n: n in self.registry or n in self.callsigns)
        spec = self.registry.get(command.name)
        if spec is None:
            if not command.argtext and (command.name in self.callsigns or command.name in self.waypoints
                                        or (callable(self.navdb_known) and self.navdb_known(command.name))):
                return  # a position query
            raise CommandError(f"unknown command {command.name}")
        self.last_acidx = -1
        if spec.raw:
            if spec.validator is not None:
                spec.validator(command.argtext, self)
            return
        values = spec.bind(command.argtext, self)
        if spec.nested and values and isinstance(values[-1], str) and values[-1]:
            self.check_nested(values[-1])

    def check_nested(self, text: str) -> None:
        if self.depth >= MAX_NESTING:  # 2,000 nested SCHEDULEs once ended --strict in a RecursionError
            raise CommandError(f"commands nested more than {MAX_NESTING} deep (SCHEDULE/DELAY/AT ... DO)")
        try:
            nested = parse_line(text)
        except ScenarioSyntaxError as exc:
            raise CommandError(f'in "{_short(text)}": {exc.message}') from None
        self.depth += 1
        try:
            self.check(nested)
        except (ArgumentError, CommandError) as exc:
            raise CommandError(f'in "{_short(text)}": {exc.message}') from None
        finally:
            self.depth -= 1


MAX_NESTING = 50


def _short(text: str, limit: int = 80) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def validate_scenario(
    text: str,
    path: str,
    registry: CommandRegistry,
    navdb_known: Callable[[str], bool] | None = None,
    file_finder: Callable[[str], Path | None] | None = None,
) -> list[ScenarioSyntaxError]:
    """All errors of a scenario, in line order (empty list: the file is valid)."""
    parsed = parse_scenario(text, path, is_command=registry.__contains__)
    errors: list[ScenarioSyntaxError] = list(parsed.errors)
    checker = _Checker(navdb_known=navdb_known, registry=registry, file_finder=file_finder)
    for timed in parsed.commands:
        spec = registry.get(timed.command.name)
        name = spec.name if spec else timed.command.name
        first, _ = next_arg(timed.command.argtext)
        if name == "CRE" and first:
            checker.callsigns.add(first.upper())
        elif name == "MCRE":
            checker.any_callsign = True
        elif name == "DEFWPT" and first:
            checker.waypoints.add(first.upper())
    for timed in parsed.commands:
        try:
            checker.check(timed.command)
        except AamsimError as exc:
            message = getattr(exc, "message", str(exc))
            errors.append(ScenarioSyntaxError(f"{timed.command.name}: {message}", timed.source))
    errors.sort(key=lambda e: (e.source.path, e.source.line))
    return errors


__all__ = ["SourceRef", "validate_scenario"]
