"""Messages a simulation produces: errors, warnings, notes and ECHO text.

Errors are worded ``file:line: message``. Every message is kept (the run
directory's ``messages.log`` and the bridge replies read them) and passed to
listeners (the CLI prints them) and to the ``aamsim`` logger.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

from aamsim.errors import SourceRef

LOG = logging.getLogger("aamsim")
LOG.addHandler(logging.NullHandler())
_LEVELS = {"error": logging.ERROR, "warning": logging.WARNING, "note": logging.INFO, "echo": logging.INFO}


@dataclass(frozen=True)
class Message:
    kind: str  # error | warning | note | echo
    text: str
    source: SourceRef | None = None
    simt: float = 0.0

    def __str__(self) -> str:
        prefix = f"{self.source}: " if self.source is not None else ""
        label = "" if self.kind in ("echo",) else f"{self.kind}: "
        return f"{prefix}{label}{self.text}"


@dataclass
class Reporter:
    messages: list[Message] = field(default_factory=list)
    listeners: list[Callable[[Message], None]] = field(default_factory=list)

    def emit(self, kind: str, text: str, source: SourceRef | None = None, simt: float = 0.0) -> Message:
        msg = Message(kind, text, source, simt)
        self.messages.append(msg)
        LOG.log(_LEVELS.get(kind, logging.INFO), "%s", msg)
        for listener in self.listeners:
            listener(msg)
        return msg

    def errors(self) -> list[Message]:
        return [m for m in self.messages if m.kind == "error"]

    def since(self, start: int) -> list[Message]:
        return self.messages[start:]
