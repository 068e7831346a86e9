"""The stop signals, SIGINT (Ctrl-C) and SIGTERM (``kill``), handled for the length of a block.

One pattern for every long-running command: ``aamsim run`` ends at a step boundary, the viewer and the
live run's last picture raise KeyboardInterrupt, the simulation server stops serving. The handlers that
were there before the block are put back after it. Python allows signal handlers only in the main
thread; elsewhere the block runs with nothing installed.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from types import FrameType
from typing import Any, Self

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)

Handler = Callable[[int, FrameType | None], Any]


class StopSignals:
    """``with StopSignals(handler):`` the stop signals call ``handler(signum, frame)`` inside the block.

    ``StopSignals(signal.default_int_handler)`` makes both raise KeyboardInterrupt, whatever the process
    inherited: a background job of a script starts with SIGINT *ignored*, and would otherwise carry on
    after Ctrl-C and ``kill -INT``.
    """

    def __init__(self, handler: Handler) -> None:
        self._handler = handler
        self._previous: dict[int, Any] = {}

    @property
    def installed(self) -> bool:
        """Whether the handlers are in place (False outside the main thread and outside the block)."""
        return bool(self._previous)

    def __enter__(self) -> Self:
        if threading.current_thread() is threading.main_thread():
            for signum in STOP_SIGNALS:
                self._previous[signum] = signal.signal(signum, self._handler)
        return self

    def replace(self, handler: Handler) -> None:
        """Handle the stop signals with ``handler`` for the rest of the block (nothing outside the main thread)."""
        for signum in self._previous:
            signal.signal(signum, handler)

    def __exit__(self, *exc: object) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous.clear()
