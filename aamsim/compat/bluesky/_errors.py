"""What a caller gets for a BlueSky name the shim does not provide.

Every such name raises :class:`NotProvided`, a ``NotImplementedError`` that names it
and points at the table of ``docs/bluesky-api.md``. It is also an
``AttributeError`` (attributes) or an ``ImportError`` (modules), so ``hasattr`` and
``try: import ... except ImportError`` keep their usual meaning.
"""

from __future__ import annotations

from typing import Any, NoReturn

TABLE = "docs/bluesky-api.md"


def _message(name: str, hint: str = "") -> str:
    why = f" ({hint})" if hint else ""
    return (f"{name} is not provided by aamsim's BlueSky API (aamsim.compat.bluesky){why}; "
            f"{TABLE} lists every BlueSky name it provides and how each differs from BlueSky 1.1.1")


class NotProvided(NotImplementedError, AttributeError):
    """A BlueSky attribute or function the shim does not provide."""


class NotProvidedModule(NotImplementedError, ImportError):
    """A BlueSky module the shim does not provide."""


def not_provided(name: str, hint: str = "") -> NotProvided:
    """The exception for attribute ``name`` (``bluesky.traf.cd``, ...)."""
    return NotProvided(_message(name, hint))


def not_provided_module(name: str, hint: str = "") -> NotProvidedModule:
    """The exception for module ``name`` (``bluesky.network``, ...)."""
    exc = NotProvidedModule(_message(name, hint))
    exc.name = name
    return exc


class Unprovided:
    """A stand-in for a BlueSky object the shim does not provide: any attribute raises :class:`NotProvided`."""

    __slots__ = ("_hint", "_name")

    def __init__(self, name: str, hint: str = "") -> None:
        object.__setattr__(self, "_name", name)
        object.__setattr__(self, "_hint", hint)

    def __getattr__(self, attr: str) -> NoReturn:
        if attr.startswith("__"):
            raise AttributeError(attr)
        raise not_provided(f"{self._name}.{attr}", self._hint)

    def __setattr__(self, attr: str, value: Any) -> NoReturn:
        raise not_provided(f"{self._name}.{attr}", self._hint)

    def __repr__(self) -> str:
        return f"<{self._name}: not provided by aamsim.compat.bluesky, see {TABLE}>"
