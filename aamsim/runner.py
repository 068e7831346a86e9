"""Run a scenario headless and write its run directory (what ``aamsim run`` does).

The run directory holds ``scenario.scn`` (the exact text that ran),
``flights.csv``, ``trajectories.csv`` (unless the log period is 0),
``summary.json`` and ``messages.log`` (every error, warning, note and ECHO).
Services that report more (conflict metrics) add their own files through
the ``finish`` callbacks in ``sim.run_outputs``.
"""

from __future__ import annotations

import hashlib
import math
import platform
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, Self

import aamsim
from aamsim.errors import ScenarioSyntaxError
from aamsim.limits import DEFAULT_LOCAL_MAX_AIRCRAFT
from aamsim.output.flights import write_flights
from aamsim.output.recorder import TrajectoryRecorder
from aamsim.output.summary_file import ProvisionalSummary, write_json_atomic
from aamsim.scenarios import resolve_scenario, shipped_names
from aamsim.simulation import Simulation, iter_flights
from aamsim.stack.validate import validate_scenario
from aamsim.stop_signals import StopSignals


class ScenarioNotFound(FileNotFoundError):
    pass


class StrictValidationFailed(Exception):
    """``--strict`` found errors; nothing was simulated."""

    def __init__(self, errors: list[ScenarioSyntaxError]):
        super().__init__(f"{len(errors)} error(s) in the scenario")
        self.errors = errors


@dataclass
class RunConfig:
    """Everything that defines a run (the CLI options)."""

    scenario: str | Path
    out_dir: Path | None = None
    until_s: float | None = None
    dt_s: float = 0.05
    seed: int | None = None
    strict: bool = False
    log_period_s: float = 1.0
    plugins: tuple[str, ...] = ()
    delete_on_arrival: bool = False
    metrics: tuple[str, ...] = ("safety", "operational")
    volumes: tuple[Any, ...] = ()  # SeparationVolume overrides (default: the paper's NMAC/LoWC)
    threads: int = 1
    text: str | None = None  # the scenario's text when it is not the whole file (a SCEN block of a batch)
    name: str | None = None  # the scenario's name (default: the file's stem)
    commands: tuple[str, ...] = ()  # stack commands run at time 0 before the scenario's own
    # Real traffic overlaid (docs/real-traffic.md): recording files or opensky:LAT0,LON0,LAT1,LON1 (live).
    overlays: tuple[str, ...] = ()
    overlay_offset: str = ""  # REPLAY's offset for the recordings: [-][[HH:]MM:]SS or @UTC-TIME
    overlay_area: tuple[float, ...] = ()  # LAT0, LON0, LAT1, LON1: only the recordings' reports in it
    max_aircraft: int | None = DEFAULT_LOCAL_MAX_AIRCRAFT  # aircraft at once; one more is a reported error


@dataclass
class RunResult:
    sim: Simulation
    out_dir: Path
    summary: dict[str, Any]
    wall_s: float
    extra: dict[str, Any] = field(default_factory=dict)


def default_out_dir(scenario: Path) -> Path:
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    base = Path("runs") / f"{scenario.stem}-{stamp}"
    candidate, k = base, 1
    while candidate.exists():
        candidate = base.with_name(f"{base.name}-{k}")
        k += 1
    return candidate


def build_simulation(cfg: RunConfig, path: Path, text: str) -> Simulation:
    """A simulation with the run's settings, plugins and services attached."""
    sim = Simulation(seed=cfg.seed, dt=cfg.dt_s, threads=cfg.threads, max_aircraft=cfg.max_aircraft)
    sim.settings.delete_on_arrival = cfg.delete_on_arrival
    sim.files.name = cfg.name or path.stem
    sim.files.path = path
    sim.files.text = text
    from aamsim.services import attach_run_services

    attach_run_services(sim, sim.services, cfg)
    from aamsim.plugins import load_plugin

    for name in cfg.plugins:
        load_plugin(sim, name)
    return sim


def run_scenario(
    cfg: RunConfig,
    progress: Callable[[Simulation, float], None] | None = None,
    listener: Callable[[Any], None] | None = None,
    setup: Callable[[Simulation, str], None] | None = None,
) -> RunResult:
    """Simulate a scenario and write its run directory.

    ``setup(sim, scenario_text)`` runs once the scenario is loaded, before the
    first step (``aamsim run --view`` attaches the live viewer there).

    Raises:
        ScenarioNotFound: the scenario file does not exist (here or shipped).
        StrictValidationFailed: ``strict`` and the file has errors.
    """
    # With its text given, the scenario needs no file here (a batch job on another node).
    path = Path(cfg.scenario) if cfg.text is not None else resolve_scenario(cfg.scenario)
    if path is None:
        raise ScenarioNotFound(f"scenario not found: {cfg.scenario} (neither a file nor a shipped scenario; "
                               f"shipped: {', '.join(shipped_names())})")
    text = cfg.text if cfg.text is not None else path.read_text(encoding="utf-8", errors="replace")
    sim = build_simulation(cfg, path, text)
    if listener is not None:
        sim.reporter.listeners.append(listener)
    if cfg.strict:
        errors = validate_scenario(text, str(path), sim.commands, sim.navdb.known, sim.find_file)
        if errors:
            raise StrictValidationFailed(errors)
    out_dir = cfg.out_dir or default_out_dir(path)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "scenario.scn").write_text(text, encoding="utf-8")
    recorder = None
    if cfg.log_period_s > 0:
        recorder = TrajectoryRecorder(out_dir / "trajectories.csv", cfg.log_period_s)
        recorder.attach(sim)
    # A run killed outright still leaves a summary: provisional ones from now on, replaced at the end.
    provisional = ProvisionalSummary(out_dir / "summary.json", lambda wall: make_summary(sim, cfg, path, wall),
                                     sim.report, before=recorder.sync if recorder is not None else None)
    provisional.write(0.0)
    for line in cfg.commands:
        sim.stack(line)
    start_overlays(sim, cfg)
    sim.load_scenario(path, text=text)
    if setup is not None:
        setup(sim, text)
    wall0 = time.perf_counter()

    def chunk_done(s: Simulation) -> None:
        wall = time.perf_counter() - wall0
        provisional.maybe_write(wall)
        if progress is not None:
            progress(s, wall)

    with StopOnSignal(sim) as stop:
        try:
            try:
                sim.run(until_s=cfg.until_s, progress=chunk_done, progress_interval_s=10.0)
            finally:
                wall = time.perf_counter() - wall0
                if recorder is not None:
                    recorder.flush()  # its thread writes the last rows while the other outputs are made
            stop.hold()  # a second signal now would leave half-written files: the outputs come first
            write_flights(out_dir / "flights.csv", iter_flights(sim))  # while the thread writes the last rows
            if recorder is not None:
                # Its last rows: a write that failed is reported now, so the summary and messages.log
                # count it, and a summary that says complete comes after them.
                recorder.close()
            summary = make_summary(sim, cfg, path, wall)
            summary["complete"] = True
            summary["interrupted"] = stop.signal_name is not None
            if stop.signal_name is not None:
                summary["interrupted_by"] = stop.signal_name
                sim.report("note", f"{stop.signal_name}: run stopped at sim time {sim.simt:.2f} s; outputs written")
            for finish in sim.run_outputs.finishers:
                finish(sim, out_dir, summary)
            with open(out_dir / "messages.log", "w", encoding="utf-8") as fh:
                fh.writelines(f"{msg.simt:10.2f} {msg}\n" for msg in sim.reporter.messages)
            write_json_atomic(out_dir / "summary.json", summary)
        finally:
            if recorder is not None:
                recorder.close()  # (a second close does nothing)
    return RunResult(sim, out_dir, summary, wall)


class OverlayError(Exception):
    """An overlay that cannot start (recording not found or unreadable, bad offset or area)."""


def start_overlays(sim: Simulation, cfg: RunConfig) -> None:
    """Start the run's real-traffic overlays at time 0; raises :class:`OverlayError` naming the overlay."""
    if not cfg.overlays and not cfg.overlay_area:
        return  # nothing to check or start (and the readers stay unimported)
    from aamsim.errors import CommandError
    from aamsim.realtraffic.overlay import start_overlay
    from aamsim.realtraffic.replay import parse_area

    try:
        area = parse_area(list(cfg.overlay_area))
        for spec in cfg.overlays:
            start_overlay(sim, spec, cfg.overlay_offset, area)
    except (CommandError, ValueError) as err:
        raise OverlayError(f"--overlay: {err}") from None


class StopOnSignal:
    """SIGINT (Ctrl-C) and SIGTERM end the run at the next step boundary instead of killing it.

    The handler only asks the simulation to stop (as QUIT does), so the run
    ends between two steps with its state whole, and the run directory is then
    written as after a normal end, its summary saying ``"interrupted": true``.
    While the outputs are written (:meth:`hold`), further signals are ignored.
    Outside the main thread (where Python cannot install handlers) it does nothing.
    """

    def __init__(self, sim: Simulation):
        self.sim = sim
        self.signal_name: str | None = None
        self._signals = StopSignals(self._handle)

    def __enter__(self) -> Self:
        self._signals.__enter__()
        return self

    def _handle(self, signum: int, frame: Any) -> None:
        self.signal_name = self.signal_name or signal.Signals(signum).name
        self.sim.quit_requested = True

    def hold(self) -> None:
        self._signals.replace(self._handle_late)

    def _handle_late(self, signum: int, frame: Any) -> None:
        self.signal_name = self.signal_name or signal.Signals(signum).name

    def __exit__(self, *exc: object) -> None:
        self._signals.__exit__(*exc)


def make_summary(sim: Simulation, cfg: RunConfig, path: Path, wall_s: float) -> dict[str, Any]:
    flights = list(iter_flights(sim))
    simt = sim.simt
    return {
        "scenario": cfg.name or path.stem,
        "scenario_file": str(path),
        "scenario_sha256": hashlib.sha256(sim.files.text.encode("utf-8")).hexdigest(),
        "aamsim_version": aamsim.__version__,
        "python": platform.python_version(),
        "seed": cfg.seed,
        "commands": list(cfg.commands),  # run at time 0 before the scenario (aamsim run/batch --set stack=...)
        "dt_s": sim.dt,
        "threads": sim.threads,
        "until_s": cfg.until_s,
        "sim_time_s": round(simt, 6),
        "ended_by": sim.ended_by,
        "wall_time_s": round(wall_s, 4),
        "speedup": round(simt / wall_s, 2) if wall_s > 0 else None,  # None: not measured yet (valid JSON)
        "aircraft_steps": sim.aircraft_steps,
        "aircraft_steps_per_s": round(sim.aircraft_steps / wall_s, 1) if wall_s > 0 else None,
        "flights_created": len(flights),
        "flights_deleted": sum(1 for f in flights if not math.isnan(f.deleted_s)),
        "flights_arrived": sum(1 for f in flights if f.arrived),
        "aircraft_at_end": sim.view.n,
        "errors": len(sim.reporter.errors()),
    }
