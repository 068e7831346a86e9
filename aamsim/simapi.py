"""What the built-in services see of a simulation: a typing Protocol, in a module that imports none of them.

:class:`aamsim.Simulation` imports its API mixin (:mod:`aamsim.api`), which builds the services
(:mod:`aamsim.services`: conflicts, metrics, detect and avoid, MVP, snapshots); those services, the
run-end check and the metric registry annotate the simulation they are given with
:class:`SimulationCore`, not with the concrete class, so that none of them imports
:mod:`aamsim.simulation` — not even for type checking — and the import graph of ``aamsim`` has no
cycle (issue 29). :class:`aamsim.Simulation` satisfies the protocol structurally; nothing here
runs at import or checks anything at run time.

This module imports only leaf modules (the traffic state, hooks, settings, the clock, the command
queue) and those only for type checking.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np

if TYPE_CHECKING:
    from aamsim.clock import Clock
    from aamsim.errors import SourceRef
    from aamsim.features import FeatureStates, RunOutputs
    from aamsim.hooks import Hooks
    from aamsim.settings import SimSettings
    from aamsim.stack.queue import CommandQueue
    from aamsim.traffic.conditions import Conditions
    from aamsim.traffic.traffic import FlightRecord, Traffic
    from aamsim.traffic.view import TrafficView
    from aamsim.units import Speed

# Which aircraft an intent applies to: a callsign, a slot, a list of callsigns or an int array of slots.
Target = str | int | Sequence[str] | np.ndarray

__all__ = ["SimulationCore", "Target"]


class SimulationCore(Protocol):
    """The part of :class:`aamsim.Simulation` that its services, the run-end check and metrics use.

    Read-only members are properties here so that a plain attribute (``sim._traffic``) or a property
    (``sim.simt``) satisfies them alike.
    """

    # ---------------------------------------------------------------- state
    @property
    def _traffic(self) -> Traffic:
        """The aircraft state: private to the engine, read by the built-in services only (issue 29).

        Everything else reads it through :attr:`view` and changes it through the intents.
        """
        ...

    @property
    def view(self) -> TrafficView:
        """Read-only named arrays of the traffic, SI units."""
        ...

    @property
    def settings(self) -> SimSettings:
        """The simulation's settings (detection, resolution, ...)."""
        ...

    @property
    def hooks(self) -> Hooks:
        """The hook lists services attach to."""
        ...

    @property
    def _clock(self) -> Clock:
        """The simulation clock (private to the engine; everyone else reads ``simt``, ``simt_us``, ``dt``)."""
        ...

    @property
    def conditions(self) -> Conditions:
        """Conditional commands not yet fired."""
        ...

    @property
    def queue(self) -> CommandQueue:
        """Timed commands not yet run."""
        ...

    @property
    def pending_work(self) -> list[Callable[[], bool]]:
        """Functions that say whether some service still has work to do (the run-end check)."""
        ...

    @property
    def features(self) -> FeatureStates:
        """Per-simulation state of the optional features, by class."""
        ...

    @property
    def run_outputs(self) -> RunOutputs:
        """What ``aamsim run`` writes when the run ends."""
        ...

    @property
    def simt(self) -> float:
        """Simulated time [s]."""
        ...

    @property
    def simt_us(self) -> int:
        """Simulated time [us]."""
        ...

    def flights(self, real_traffic: bool = False) -> Iterator[FlightRecord]:
        """Closed flights followed by the open ones (the AAM ones, or with ``real_traffic`` the replayed)."""
        ...

    def is_quiescent(self) -> bool:
        """Whether nothing can happen any more (no aircraft, commands, conditions or pending work)."""
        ...

    # ---------------------------------------------------------------- messages
    def report(self, kind: str, text: str, source: SourceRef | None = None) -> None:
        """Emit a message."""
        ...

    def note_once(self, key: str, text: str, source: SourceRef | None = None) -> None:
        """Emit a note the first time ``key`` is seen."""
        ...

    # ---------------------------------------------------------------- intents (aamsim.api)
    def select_speed(self, targets: Target, speed: Speed | float | np.ndarray) -> None:
        """Select a speed (CAS [m/s] for a bare float); VNAV speed goes off."""
        ...

    def command_resolution(self, targets: Target, trk_deg: float | np.ndarray, gs_mps: float | np.ndarray,
                           vs_mps: float | np.ndarray, alt_m: float | np.ndarray) -> None:
        """Command a resolution velocity (track [deg], ground speed [m/s], vertical speed [m/s], altitude [m])."""
        ...

    def follow_resolution(self, targets: Target, on: bool | np.ndarray) -> None:
        """Whether the aircraft fly their commanded resolution."""
        ...

    def set_navigation(self, target: str | int, lnav: bool | None = None, vnav: bool | None = None,
                       vnav_speed: bool | None = None) -> None:
        """Switch LNAV, VNAV and VNAV speed control."""
        ...

    def resume_route(self, target: str | int) -> None:
        """Fly the route again (LNAV and VNAV on)."""
        ...

    def select_heading(self, target: str | int, heading_deg: float) -> None:
        """Fly a heading [deg true]; LNAV off."""
        ...
