"""The one process-wide state of the shim: BlueSky's API is process-wide by definition.

``bluesky.traf``, ``bluesky.sim`` and the command stack are singletons of the
process in BlueSky, and code written for it reaches them through the module
(``bs.traf.lat``). Everything they need lives in one :class:`ProcessState`;
:func:`bluesky.init() <aamsim.compat.bluesky.init>` puts a
:class:`~aamsim.compat.bluesky._session.Session` (one aamsim ``Simulation``) in it.
Code that wants several independent simulations in one process uses
:class:`aamsim.Simulation` directly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from aamsim.compat.bluesky._session import Session


@dataclass
class ProcessState:
    """BlueSky's process-wide objects: the session (after ``init``) and the stack of commands to run."""

    session: Session | None = None
    # BlueSky's Stack.cmdstack: command lines stacked and not yet run (kept across init, as BlueSky's).
    pending: list[str] = field(default_factory=list)


PROCESS = ProcessState()


def current_session(what: str) -> Session:
    """The session, or a clear error when ``bluesky.init()`` has not been called yet."""
    session = PROCESS.session
    if session is None:
        raise RuntimeError(f"{what}: call bluesky.init(mode='sim', detached=True) first (aamsim.compat.bluesky)")
    return session
