"""Per-simulation state of the optional features, typed: no dict of objects by string key.

A feature that keeps state in a simulation (the shapes, the deletion area, turbulence, the real-traffic
replays, a plugin's settings) owns one object of its own class in the simulation's
:class:`FeatureStates`, found by that class (``sim.features.get(Shapes)`` is a ``Shapes | None``), so
that two features cannot collide on a name and a type checker knows what comes back. What ``aamsim
run`` collects for its run directory is the typed :class:`RunOutputs` (``sim.run_outputs``).

This module imports nothing of the simulator: the features import it, not the other way round.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")

# What a run output receives: the simulation, the run directory and the summary to complete.
RunFinisher = Callable[[Any, Path, dict[str, Any]], None]

__all__ = ["FeatureStates", "RunFinisher", "RunOutputs"]


class FeatureStates:
    """One state object per feature class, created by the feature on its first use."""

    def __init__(self) -> None:
        self._states: dict[type, object] = {}

    def get(self, kind: type[T]) -> T | None:
        """The state of class ``kind``, or None while the feature was never used."""
        state = self._states.get(kind)
        assert state is None or isinstance(state, kind)  # kept under its own class by add
        return state

    def add(self, state: T) -> T:
        """Keep ``state`` as its class's state; a second state of one class is an error."""
        kind = type(state)
        if kind in self._states:
            raise ValueError(f"this simulation already has a {kind.__name__}")
        self._states[kind] = state
        return state

    def __contains__(self, kind: type) -> bool:
        return kind in self._states


@dataclass
class RunOutputs:
    """What ``aamsim run`` writes when the run ends, and what could not be written.

    ``collecting`` is set by ``aamsim run`` (:func:`aamsim.services.attach_run_services`); the features
    that add files to the run directory (the real-traffic replays) add their finisher only then.
    """

    collecting: bool = False
    finishers: list[RunFinisher] = field(default_factory=list)
    write_failures: list[str] = field(default_factory=list)  # output files that failed: the run exits 1

    def add(self, finish: RunFinisher) -> None:
        """Call ``finish(sim, out_dir, summary)`` when the run ends."""
        self.finishers.append(finish)
