"""The simulation's built-in services, wired in one place.

:func:`build_services` creates conflict detection, metrics, detect and avoid
(:mod:`aamsim.resolution`) and the traffic snapshot stream (:mod:`aamsim.snapshots`), attaches their
hooks and sets the typed field ``sim.services`` (a :class:`Services`); every
entry point (``aamsim run``, the episode engine, the simulation server) calls
it once, before the scenario loads. Settings have one owner each: the
detection settings (``ASAS``, ``ZONER``, ``ZONEDH``, ``DTLOOK``, ``DT ASAS``)
live in ``sim.settings`` and the service reads them when it runs, so ``DT ASAS
5`` changes the check interval from then on; the separation volumes live in
the conflict service (``SEPVOLUME``); the metric groups in the metrics service;
the detect-and-avoid thresholds in the DAA service (``DAA``), which acts only
while ``RESO DAA`` is on; BlueSky's resolution settings (``RMETHH``, ``RFACH``,
``PRIORULES``, ...) in the MVP service, which acts only while ``RESO MVP`` is on.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aamsim.conflicts.service import PAPER_VOLUMES, ConflictService, SeparationVolume
from aamsim.metrics.service import DEFAULT_GROUPS, MetricsService, write_conflicts_csv
from aamsim.resolution.mvp_service import MVPService
from aamsim.resolution.service import DAAService
from aamsim.snapshots import SnapshotStream

if TYPE_CHECKING:
    from aamsim.simapi import SimulationCore


@dataclass(frozen=True)
class Services:
    """The built-in services of one simulation."""

    conflicts: ConflictService
    metrics: MetricsService
    snapshots: SnapshotStream  # frozen traffic snapshots for the recorder, the bridge and viewers
    daa: DAAService  # detect-and-avoid alerting and speed resolutions (idle until RESO DAA)
    mvp: MVPService  # BlueSky's Modified Voltage Potential resolution (idle until RESO MVP)


def build_services(sim: SimulationCore, volumes: tuple[SeparationVolume, ...] = PAPER_VOLUMES,
                   groups: tuple[str, ...] = DEFAULT_GROUPS) -> Services:
    """Create and attach conflict detection, metrics, DAA and MVP (once per simulation); returns ``sim.services``."""
    if sim.services is not None:
        raise RuntimeError("the simulation's services are already built")
    conflicts = ConflictService(volumes=tuple(volumes))
    conflicts.attach(sim)
    metrics = MetricsService(groups=tuple(groups))
    daa = DAAService()
    daa.attach(sim)
    mvp = MVPService()
    mvp.attach(sim)
    sim.services = Services(conflicts, metrics, SnapshotStream(sim), daa, mvp)
    return sim.services


def services_of(sim: SimulationCore) -> Services:
    """The simulation's services, built with the defaults when no entry point built them (scripts, tests)."""
    return sim.require_services()


def attach_run_services(sim: SimulationCore, cfg: Any) -> None:
    """Conflict detection and the metric groups of the run config; they write into the run directory."""
    services = build_services(sim, tuple(getattr(cfg, "volumes", None) or PAPER_VOLUMES),
                              tuple(getattr(cfg, "metrics", DEFAULT_GROUPS)))
    conflicts, metrics = services.conflicts, services.metrics

    def finish(sim: SimulationCore, out_dir: Path, summary: dict[str, Any]) -> None:
        conflicts.finish(sim)
        events = conflicts.events  # built once for the metrics and the CSV
        summary["separation_volumes"] = {v.name: v.describe() for v in conflicts.volumes}
        summary.update(metrics.compute(sim, events=events))
        if services.daa.issued or services.daa.active(sim):
            summary["daa"] = services.daa.summary()
        if services.mvp.resolutions or services.mvp.active(sim):
            summary["mvp"] = services.mvp.summary()
        write_conflicts_csv(out_dir / "conflicts.csv", sim, events)

    sim.extensions.setdefault("run_outputs", []).append(finish)
