"""The simulation's built-in services, wired in one place.

:class:`Services` holds conflict detection, metrics, detect and avoid
(:mod:`aamsim.resolution`) and the traffic snapshot stream (:mod:`aamsim.snapshots`) as typed
fields; every :class:`aamsim.Simulation` builds one in its constructor (``sim.services``), and
every entry point (``aamsim run``, the episode engine, the simulation server) starts it
(:meth:`Services.start`: the hooks attach) before the scenario loads. Settings have one owner each: the
detection settings (``ASAS``, ``ZONER``, ``ZONEDH``, ``DTLOOK``, ``DT ASAS``)
live in ``sim.settings`` and the service reads them when it runs, so ``DT ASAS
5`` changes the check interval from then on; the separation volumes live in
the conflict service (``SEPVOLUME``); the metric groups in the metrics service;
the detect-and-avoid thresholds in the DAA service (``DAA``), which acts only
while ``RESO DAA`` is on; BlueSky's resolution settings (``RMETHH``, ``RFACH``,
``PRIORULES``, ...) in the MVP service, which acts only while ``RESO MVP`` is on.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from aamsim.conflicts.service import PAPER_VOLUMES, ConflictService, SeparationVolume
from aamsim.metrics.service import DEFAULT_GROUPS, MetricsService, write_conflicts_csv
from aamsim.resolution.mvp_service import MVPService
from aamsim.resolution.service import DAAService
from aamsim.snapshots import SnapshotStream

if TYPE_CHECKING:
    from aamsim.simapi import SimulationCore


class Services:
    """The built-in services of one simulation: typed fields, built once with it (``sim.services``).

    Building them costs nothing while they are idle: their hooks (conflict detection, DAA, MVP) attach
    when :meth:`start` runs, because a conflict check every ``DT ASAS`` splits the kernel's batches
    and costs up to 2.5 times the stepping of a plain simulation (measured with
    ``bench/bench_sim.py``'s scenario). Every entry point starts them (``aamsim run``, the episode
    engine, the simulation server), and so do the commands that configure them (``SEPVOLUME``,
    ``RESO``, ``DAA``, ...).
    """

    def __init__(self, sim: SimulationCore) -> None:
        self._sim = sim
        self.conflicts = ConflictService()
        self.metrics = MetricsService(conflicts=self.conflicts)
        # frozen traffic snapshots for the recorder, the bridge and viewers
        self.snapshots = SnapshotStream(sim)
        self.daa = DAAService()  # detect-and-avoid alerting and speed resolutions (idle until RESO DAA)
        self.mvp = MVPService()  # BlueSky's Modified Voltage Potential resolution (idle until RESO MVP)
        self.started = False

    def start(self, volumes: tuple[SeparationVolume, ...] | None = None,
              groups: tuple[str, ...] | None = None) -> Services:
        """Attach the hooks of conflict detection, DAA and MVP (the first call; later ones only configure).

        Args:
            volumes: the separation volumes to count events in (None: as they are; default the paper's).
            groups: the metric groups a run computes (None: as they are; default :data:`DEFAULT_GROUPS`).
        """
        if volumes is not None:
            self.conflicts.volumes = tuple(volumes)
        if groups is not None:
            self.metrics.groups = tuple(groups)
        if not self.started:
            self.started = True
            self.conflicts.attach(self._sim)
            self.daa.attach(self._sim)
            self.mvp.attach(self._sim)
        return self


def attach_run_services(sim: SimulationCore, services: Services, cfg: Any) -> None:
    """Start ``sim``'s ``services`` with the run config's volumes and metric groups; they write into the run
    directory."""
    services.start(tuple(getattr(cfg, "volumes", None) or PAPER_VOLUMES),
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

    sim.run_outputs.collecting = True
    sim.run_outputs.add(finish)
