"""The command table: name, argument spec, help text and handler per command.

It is the single source used to parse arguments, to execute commands, to list
them (``aamsim commands``) and to word errors. Each :class:`Simulation` owns
its own registry; nothing registers at import time. A handler is a plain
function marked with :func:`command`::

    @command("ALT", aliases=("ALTITUDE",))
    def alt(sim: CommandContext, acidx: AcIndex, alt: Altitude, vspd: VSpeed | None = None) -> None:
        '''ALT acid, alt, [vspd]: select an autopilot altitude.'''

and is added with ``registry.add(alt)``.
"""

from __future__ import annotations

import functools
import inspect
import typing
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, TypeVar

from aamsim.errors import ArgumentError, UnknownAircraft
from aamsim.stack.argtypes import ArgType, ParseContext
from aamsim.stack.tokens import next_arg

F = TypeVar("F", bound=Callable[..., Any])


@dataclass(frozen=True)
class CommandMeta:
    """What :func:`command` attaches to a handler."""

    name: str
    aliases: tuple[str, ...] = ()
    group: str = "simulation"
    nested: bool = False  # the last argument is itself a command line (ATALT, SCHEDULE, ...)


def command(
    name: str | None = None, *, aliases: Iterable[str] = (), group: str = "simulation", nested: bool = False
) -> Callable[[F], F]:
    """Mark a function as a stack command handler (no registration happens here)."""

    def mark(fn: F) -> F:
        meta = CommandMeta((name or fn.__name__).upper(), tuple(a.upper() for a in aliases), group, nested)
        fn.__aamsim_command__ = meta  # type: ignore[attr-defined]
        return fn

    return mark


@dataclass(frozen=True)
class Param:
    """One declared argument of a command."""

    name: str
    argtype: ArgType
    optional: bool
    default: Any = None
    variadic: bool = False

    def usage(self) -> str:
        text = f"{self.name}:{self.argtype.name}"
        if self.variadic:
            text += ",..."
        return f"[{text}]" if self.optional and not self.variadic else text


@dataclass
class CommandSpec:
    """A registered command."""

    name: str
    handler: Callable[..., Any]
    params: list[Param]
    help: str
    aliases: tuple[str, ...] = ()
    group: str = "simulation"
    raw: bool = False  # handler takes the raw argument text and parses it itself
    nested: bool = False  # the last argument is a command line
    validator: Callable[..., Any] | None = None  # static check of a raw command's arguments

    @property
    def usage(self) -> str:
        if self.raw:
            first = self.help.splitlines()[0] if self.help else self.name
            return first.split(":")[0].strip() if ":" in first else self.name
        args = ", ".join(p.usage() for p in self.params)
        return f"{self.name} {args}".strip()

    @property
    def summary(self) -> str:
        lines = [ln.strip() for ln in self.help.splitlines() if ln.strip()]
        if not lines:
            return ""
        first = lines[0]
        return first.split(":", 1)[1].strip() if ":" in first else first

    def bind(self, argtext: str, ctx: ParseContext) -> list[Any]:
        """Parse ``argtext`` into handler arguments (without the leading ``sim``)."""
        if self.raw:
            return [argtext]
        values: list[Any] = []
        rest = argtext.strip()
        for param in self.params:
            if param.variadic:
                while rest.strip():
                    if rest.lstrip().startswith(","):
                        _, rest = next_arg(rest)
                        continue
                    value, rest = param.argtype.parse(rest, ctx)
                    values.append(value)
                return values
            if not rest.strip() or rest.lstrip().startswith(","):
                if rest.strip():
                    _, rest = next_arg(rest)  # consume the empty field
                if param.optional:
                    values.append(param.default)
                    continue
                raise ArgumentError(f"missing argument {param.name} ({param.argtype.name}); usage: {self.usage}")
            try:
                value, rest = param.argtype.parse(rest, ctx)
            except UnknownAircraft:
                raise
            except ArgumentError as exc:
                raise ArgumentError(f"{param.name}: {exc.message}") from None
            values.append(value)
        if rest.strip():
            raise ArgumentError(f'unexpected extra argument(s) "{rest.strip()}"; usage: {self.usage}')
        return values


def _without_first_annotation(fn: Callable[..., Any]) -> Any:
    """An object with ``fn``'s annotations less the first parameter's (the simulation)."""
    names = list(inspect.signature(fn).parameters)
    annotations = {k: v for k, v in getattr(fn, "__annotations__", {}).items() if not names or k != names[0]}
    return type("Annotations", (), {"__annotations__": annotations, "__module__": fn.__module__,
                                    "__globals__": getattr(fn, "__globals__", None)})


def _spec_from_function(fn: Callable[..., Any], meta: CommandMeta) -> CommandSpec:
    params, raw = _declared_params(fn, meta.name)
    return CommandSpec(
        meta.name, fn, list(params), _help_text(fn), meta.aliases, meta.group, raw, meta.nested,
        getattr(fn, "__aamsim_validate__", None),
    )


@functools.lru_cache(maxsize=4096)
def _help_text(fn: Callable[..., Any]) -> str:
    """A handler's docstring, cleaned up: kept per function, as its arguments are (below)."""
    return inspect.cleandoc(fn.__doc__ or "")


@functools.lru_cache(maxsize=4096)
def _declared_params(fn: Callable[..., Any], name: str) -> tuple[tuple[Param, ...], bool]:
    """A handler's declared arguments (and whether it parses its text itself), read from its type hints.

    Reading the hints costs about 0.2 ms per handler, 0.1 s for the built-in table: every
    simulation (an episode of the environments is one) builds its table, so the result is kept
    per function. It depends on the function only (Param is frozen).
    """
    # Handlers annotate ``sim: CommandContext`` (plugins may still write ``sim: Simulation``)
    # under TYPE_CHECKING; only the argument types matter here, so the first is not resolved. Another
    # mention of the name resolves to Any, which is no argument type either (refused below, as the
    # protocol itself would be): the registry does not import the context module that names it.
    hints = typing.get_type_hints(_without_first_annotation(fn), globalns=getattr(fn, "__globals__", None),
                                  localns={"CommandContext": Any}, include_extras=True)
    sig = inspect.signature(fn)
    params: list[Param] = []
    names = list(sig.parameters)
    if not names or names[0] != "sim":
        raise TypeError(f"command {name}: handler's first parameter must be 'sim'")
    for pname in names[1:]:
        p = sig.parameters[pname]
        hint = hints.get(pname)
        argtype = _argtype_of(hint)
        if argtype is None:
            raise TypeError(f"command {name}: parameter {pname} needs an Annotated argument type")
        optional = p.default is not inspect.Parameter.empty
        variadic = p.kind == inspect.Parameter.VAR_POSITIONAL
        params.append(Param(pname, argtype, optional or variadic, None if not optional else p.default, variadic))
    if getattr(fn, "__aamsim_raw__", False):
        return (), True
    return tuple(params), False


def _argtype_of(hint: Any) -> ArgType | None:
    if hint is None:
        return None
    if typing.get_origin(hint) is typing.Annotated:
        for meta in hint.__metadata__:
            if isinstance(meta, ArgType):
                return meta
        return None
    # Optional[Annotated[...]] / Annotated[...] | None
    for arg in typing.get_args(hint):
        found = _argtype_of(arg)
        if found is not None:
            return found
    return None


def raw_arguments(fn: F) -> F:
    """Mark a handler that parses its argument text itself (e.g. ADDWPT's modes)."""
    fn.__aamsim_raw__ = True  # type: ignore[attr-defined]
    return fn


def static_validator(check: Callable[..., Any]) -> Callable[[F], F]:
    """Attach ``check(argtext, ctx)`` used by ``--strict`` to a raw-argument handler."""

    def mark(fn: F) -> F:
        fn.__aamsim_validate__ = check  # type: ignore[attr-defined]
        return fn

    return mark


@dataclass
class CommandRegistry:
    """Name -> :class:`CommandSpec`, with aliases. Duplicate names raise."""

    _specs: dict[str, CommandSpec] = field(default_factory=dict)
    _lookup: dict[str, CommandSpec] = field(default_factory=dict)

    def add(self, fn: Callable[..., Any], name: str | None = None) -> CommandSpec:
        """Register a handler marked with :func:`command` (or give ``name``)."""
        meta: CommandMeta | None = getattr(fn, "__aamsim_command__", None)
        if meta is None:
            if name is None:
                raise TypeError(f"{fn!r} is not marked with @command and no name was given")
            meta = CommandMeta(name.upper())
        elif name is not None:
            meta = CommandMeta(name.upper(), meta.aliases, meta.group, meta.nested)
        spec = _spec_from_function(fn, meta)
        for key in (spec.name, *spec.aliases):
            if key in self._lookup:
                raise ValueError(f"command name {key} is already registered")
        self._specs[spec.name] = spec
        for key in (spec.name, *spec.aliases):
            self._lookup[key] = spec
        return spec

    def add_all(self, fns: Iterable[Callable[..., Any]]) -> None:
        for fn in fns:
            self.add(fn)

    def remove(self, name: str) -> None:
        spec = self._specs.pop(name.upper())
        for key in (spec.name, *spec.aliases):
            self._lookup.pop(key, None)

    def get(self, name: str) -> CommandSpec | None:
        return self._lookup.get(name.upper())

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name.upper() in self._lookup

    def specs(self) -> list[CommandSpec]:
        """All commands, sorted by name."""
        return [self._specs[k] for k in sorted(self._specs)]
