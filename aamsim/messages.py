"""Messages a simulation produces: errors, warnings, notes and ECHO text.

Errors are worded ``file:line: message``. Every message is kept (the run
directory's ``messages.log`` and the bridge replies read them) and passed to
listeners (the CLI prints them) and to the ``aamsim`` logger.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Callable
from dataclasses import dataclass, field

from aamsim.errors import SourceRef

LOG = logging.getLogger("aamsim")
LOG.addHandler(logging.NullHandler())
_LEVELS = {"error": logging.ERROR, "warning": logging.WARNING, "note": logging.INFO, "echo": logging.INFO}
# Control characters other than line feed and tab (C0, DEL, C1) and the bidirectional overrides: a
# scenario's ECHO (or a bad token quoted in an error) reaches the terminal, where ESC sequences
# clear the screen, retitle the window or hide text, and U+202E reverses what follows.
_UNPRINTABLE = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def printable(text: str) -> str:
    """``text`` with its control characters shown as escapes (``\\x1b``), line feeds and tabs kept."""
    return _UNPRINTABLE.sub(lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 256 else
                            f"\\u{ord(m.group()):04x}", text)


@dataclass(frozen=True)
class Message:
    kind: str  # error | warning | note | echo
    text: str
    source: SourceRef | None = None
    simt: float = 0.0

    def __str__(self) -> str:
        prefix = printable(f"{self.source}: ") if self.source is not None else ""  # a file name may hold them too
        label = "" if self.kind in ("echo",) else f"{self.kind}: "
        return f"{prefix}{label}{self.text}"


@dataclass
class Reporter:
    messages: list[Message] = field(default_factory=list)
    listeners: list[Callable[[Message], None]] = field(default_factory=list)

    def emit(self, kind: str, text: str, source: SourceRef | None = None, simt: float = 0.0) -> Message:
        """Keep a message and pass it on; control characters in it are escaped (see :func:`printable`)."""
        msg = Message(kind, printable(text), source, simt)
        self.messages.append(msg)
        LOG.log(_LEVELS.get(kind, logging.INFO), "%s", msg)
        for listener in self.listeners:
            listener(msg)
        return msg

    def errors(self) -> list[Message]:
        return [m for m in self.messages if m.kind == "error"]

    def since(self, start: int) -> list[Message]:
        return self.messages[start:]
