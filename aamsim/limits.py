"""What a simulation may do: the bound on its traffic, and the limits a server sets on each client's session.

A local run (``aamsim run``, an environment in this process) has one: at most
:data:`DEFAULT_LOCAL_MAX_AIRCRAFT` aircraft at once (``aamsim run --max-aircraft``,
``Simulation(max_aircraft=...)``), so that a typo such as ``MCRE 100000`` is a reported error,
not a run that crawls through gigabytes. The simulation server (:mod:`rlbridge.server`) sets
tighter ones on every session it creates, so that one client can neither reach the network
through the simulation nor make one request take minutes and gigabytes. They live on the
simulation, not in its settings: ``RESET`` (which restores the settings) keeps them.
"""

from __future__ import annotations

from dataclasses import dataclass

# Aircraft one session of ``aamsim serve`` may fly at once (``--max-aircraft``). With the conflict check's pair bound
# (:data:`aamsim.conflicts.service.MAX_PAIRS_PER_CHECK`) every step of a session stays bounded.
DEFAULT_MAX_AIRCRAFT = 10_000

# Aircraft a local simulation may fly at once (``aamsim run --max-aircraft``, ``Simulation(max_aircraft=...)``).
# Far above real traffic: the shipped day of New York traffic (4,051 flights) has at most 35 airborne at
# once (docs/viewer.md), and the largest benches fly 10,000 (bench/bench_sim.py, bench/bench_conflicts.py).
DEFAULT_LOCAL_MAX_AIRCRAFT = 20_000
LOCAL_LIMITS_WHY = "a limit of this simulation (aamsim run --max-aircraft N, Simulation(max_aircraft=N))"


@dataclass(frozen=True)
class SimulationLimits:
    """Limits of one simulation (by default a local one's: live data allowed, 20,000 aircraft).

    Attributes:
        live_data: live overlays may poll the network (``REPLAY OPENSKY``, ``overlay=opensky:...``).
        max_aircraft: aircraft that may fly at once; creating one more is an error (None: no limit).
        why: how the operator lifts a limit, added to every refusal.
    """

    live_data: bool = True
    max_aircraft: int | None = DEFAULT_LOCAL_MAX_AIRCRAFT
    why: str = LOCAL_LIMITS_WHY

    def refusal(self, what: str) -> str:
        """The message of a refused request: ``what`` and how to allow it."""
        return f"{what}{'; ' + self.why if self.why else ''}"

    def room(self, flying: int) -> int | None:
        """How many more aircraft may be created while ``flying`` fly (None: any number)."""
        return None if self.max_aircraft is None else max(self.max_aircraft - flying, 0)
