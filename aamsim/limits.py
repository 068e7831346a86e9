"""What a simulation run for someone else may do: the limits a server sets on each client's session.

A local run (``aamsim run``, an environment in this process) has none of them. The simulation
server (:mod:`rlbridge.server`) sets them on every session it creates, so that one client can
neither reach the network through the simulation nor make one request take minutes and
gigabytes. They live on the simulation, not in its settings: ``RESET`` (which restores the
settings) keeps them.
"""

from __future__ import annotations

from dataclasses import dataclass

# Aircraft one session of ``aamsim serve`` may fly at once (``--max-aircraft``). With the conflict check's pair bound
# (:data:`aamsim.conflicts.service.MAX_PAIRS_PER_CHECK`) every step of a session stays bounded.
DEFAULT_MAX_AIRCRAFT = 10_000


@dataclass(frozen=True)
class SimulationLimits:
    """Limits of one simulation (none by default).

    Attributes:
        live_data: live overlays may poll the network (``REPLAY OPENSKY``, ``overlay=opensky:...``).
        max_aircraft: aircraft that may fly at once; creating one more is an error (None: no limit).
        why: how the operator lifts a limit, added to every refusal.
    """

    live_data: bool = True
    max_aircraft: int | None = None
    why: str = ""

    def refusal(self, what: str) -> str:
        """The message of a refused request: ``what`` and how to allow it."""
        return f"{what}{'; ' + self.why if self.why else ''}"
