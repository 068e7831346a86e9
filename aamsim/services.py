"""Built-in services attached to every ``aamsim run`` (conflict detection and metrics)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aamsim.simulation import Simulation


def attach_run_services(sim: Simulation, cfg: Any) -> None:
    """Attach the services a run reports on. Filled in by the metrics package."""
    sim.extensions.setdefault("run_outputs", [])
