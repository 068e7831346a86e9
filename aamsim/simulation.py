"""The :class:`Simulation`: one object that owns a whole simulated world.

It holds the clock (integer microseconds, so times are exact), the traffic,
the command table and the queue of timed commands, the hooks, conditional
commands, named waypoints, the random generator and every setting. Nothing
lives in module globals: two simulations in one process are independent.

A step follows BlueSky's order: the commands due now run, the performance
envelope refreshes on its 1 s timer, the clock advances, then the traffic is
updated by the Numba kernel. Between events the kernel advances many steps
per call; events (a command due, a periodic hook, a waypoint reached, a
conditional command firing) split the batches so that results are identical
to stepping one by one.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numba
import numpy as np

from aamsim.api import SimulationAPI
from aamsim.clock import Clock, TimeStepError
from aamsim.errors import CommandError, SourceRef
from aamsim.features import FeatureStates, RunOutputs
from aamsim.geo import qdrdist
from aamsim.hooks import Hooks
from aamsim.limits import DEFAULT_LOCAL_MAX_AIRCRAFT, SimulationLimits
from aamsim.messages import Reporter
from aamsim.navdb import NavDatabase
from aamsim.scenario_files import ScenarioFiles
from aamsim.scheduler import Scheduler
from aamsim.services import Services
from aamsim.settings import SimSettings
from aamsim.stack.context import CommandContext
from aamsim.stack.executor import CommandExecutor
from aamsim.stack.parser import Command, ParsedScenario, parse_scenario
from aamsim.stack.queue import CommandQueue, to_us
from aamsim.stack.registry import CommandRegistry
from aamsim.threads import check_threads
from aamsim.traffic import intents
from aamsim.traffic.autopilot import pass_waypoint
from aamsim.traffic.conditions import Conditions
from aamsim.traffic.kernel import (
    STATUS_CONDITION,
    STATUS_DONE,
    STATUS_NONFINITE,
    STATUS_REACHED,
    advance,
    advance_parallel,
)
from aamsim.traffic.performance import PerformanceTable
from aamsim.traffic.traffic import FlightRecord, Traffic
from aamsim.traffic.wind import WindField
from aamsim.units import FT, KTS, MAX_ALTITUDE_FT, MAX_CALLSIGN_CHARS, MIN_ALTITUDE_FT, Speed

# Fewest aircraft for which the parallel kernel is used: its threads meet after every step, and below
# this a sleeping thread's wake-up costs more than its half of the step. Measured on the idle 2-core
# development machine (`python bench/bench_sim.py --threads 1,2`, 2026-11-29): two threads ran 1,000
# aircraft at 0.45x the serial kernel's speed, 2,000 at 0.77x, 3,000 at 0.96x, 4,000 at 1.10x, 10,000
# at 1.37x. Below the threshold a thread count above 1 leaves the step serial (never slower).
PARALLEL_MIN_AIRCRAFT = 4000


# What a batch does after a kernel call (Simulation._after_kernel).
AFTER_BOUNDARY, AFTER_CONTINUE, AFTER_TESTED, AFTER_LAST_STEP = 0, 1, 2, 3

OVERSPEED_FACTOR = 2.0  # a created speed beyond this times the type's maximum is a typo (limited)
MAX_MACH = 5.0  # for types without a Mach limit (rotorcraft: mmo = inf)


class Simulation(SimulationAPI):
    """A simulated airspace: clock, traffic, command stack, hooks and plugins.

    It is assembled from parts with one job each: the :class:`~aamsim.clock.Clock`
    and the :class:`~aamsim.scheduler.Scheduler` (what is due when), the
    :class:`~aamsim.scenario_files.ScenarioFiles`, the command stack
    (:class:`~aamsim.stack.executor.CommandExecutor`, whose handlers receive this
    object as a :class:`~aamsim.stack.context.CommandContext`), the traffic, and
    the services. What stays here is the stepping loop that ties them together.

    ``max_aircraft`` bounds the aircraft flying at once (default
    :data:`~aamsim.limits.DEFAULT_LOCAL_MAX_AIRCRAFT`, None: no bound): a creation past it is a
    reported error and the run goes on (:mod:`aamsim.limits`).
    """

    STATE_INIT, STATE_OP, STATE_HOLD = "INIT", "OP", "HOLD"

    def __init__(
        self,
        seed: int | None = None,
        dt: float = 0.05,
        performance: PerformanceTable | None = None,
        use_bluesky_navdata: bool = True,
        register_builtins: bool = True,
        threads: int | None = None,
        traffic: Traffic | None = None,
        max_aircraft: int | None = DEFAULT_LOCAL_MAX_AIRCRAFT,
    ):
        try:
            self._clock = Clock(dt)  # the one check every entry point shares (aamsim.clock)
        except TimeStepError as exc:
            raise CommandError(f"DT: {exc}") from None
        self.settings = SimSettings()
        self.threads = 1
        self.set_threads(check_threads(threads))
        self.seed = seed
        self._rng = np.random.default_rng(seed)
        self.state = self.STATE_INIT
        # An empty Traffic of its own, or a block of a pool that several simulations share (aamsim.worlds).
        self._traffic = traffic if traffic is not None else Traffic()
        if self._traffic.n:
            raise ValueError("a new simulation starts with an empty traffic")
        self._wind = WindField()
        self.hooks = Hooks()
        self.scheduler = Scheduler(self._clock, self.hooks)
        self.commands = CommandRegistry()
        self.reporter = Reporter()
        self.executor = CommandExecutor(self, self.commands, self.scheduler.queue, self.report)
        self.files = ScenarioFiles()
        if max_aircraft is not None and (isinstance(max_aircraft, bool) or not isinstance(max_aircraft, int)
                                         or max_aircraft < 1):
            raise ValueError(f"max_aircraft must be a whole number of at least 1 (or None: no bound), not "
                             f"{max_aircraft!r}")
        # The local bound on aircraft at once; a server replaces these with its client's session limits.
        self.limits = SimulationLimits(max_aircraft=max_aircraft)
        self.conditions = Conditions()
        self.navdb = NavDatabase(use_bluesky_data=use_bluesky_navdata)
        self.performance = performance or PerformanceTable()
        self.flight_log: list[FlightRecord] = []
        self.plugins: dict[str, Any] = {}
        self.features = FeatureStates()  # per-simulation state of optional features, by class (aamsim.features)
        self.run_outputs = RunOutputs()  # what aamsim run writes at the end (aamsim.runner)
        # Conflict detection, metrics, DAA, MVP, snapshots: built here, idle until started (aamsim.services).
        self.services = Services(self)
        self.aircraft_steps = 0
        # Services with work still to come (a replay with tracks ahead) keep a run going: see is_quiescent.
        self.pending_work: list[Callable[[], bool]] = []
        self.quit_requested = False
        self.ended_by = ""  # why the last run() stopped (see run)
        self._noted: set[str] = set()
        if register_builtins:
            from aamsim.stack.commands import register_builtin_commands

            register_builtin_commands(self.commands)

    # ------------------------------------------------------------------ clock
    @property
    def simt(self) -> float:
        """Simulation time [s]."""
        return self._clock.simt_us / 1_000_000

    @property
    def simt_us(self) -> int:
        """Simulation time [us] (exact)."""
        return self._clock.simt_us

    @property
    def dt(self) -> float:
        """Time step [s]."""
        return self._clock.dt_s

    @property
    def dt_us(self) -> int:
        return self._clock.dt_us

    def set_dt(self, dt_s: float) -> None:
        """Set the time step [s]; raises :class:`CommandError` outside :mod:`aamsim.clock`'s bounds."""
        try:
            self._clock.set_dt(dt_s)
        except TimeStepError as exc:
            raise CommandError(f"DT: {exc}") from None

    @property
    def rng(self) -> np.random.Generator:
        """The simulation's random generator (SEED sets it)."""
        return self._rng

    def reseed(self, seed: int | None) -> None:
        self.seed = seed
        self._rng = np.random.default_rng(seed)

    def set_threads(self, threads: int) -> None:
        """Use ``threads`` Numba threads to step the traffic (1: serial, the default).

        The parallel kernel gives the same results bit for bit; it only runs
        when there are at least :data:`PARALLEL_MIN_AIRCRAFT` aircraft, below
        which meeting the threads every step costs more than it saves. It
        pays only with idle cores (see ``bench/bench_sim.py --threads``).
        ``Simulation(threads=None)`` takes ``AAMSIM_THREADS`` (:mod:`aamsim.threads`);
        more threads than cores is an error.
        """
        threads = check_threads(threads)
        if threads > 1:
            # The kernel's threads meet after every step. With OpenMP's default
            # spin-waiting, a machine with more busy threads than cores ran the
            # parallel kernel 20 times slower than the serial one (measured);
            # sleeping waits cost little. It applies if set before Numba
            # starts its threads, and only when the user has not chosen.
            os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
        self.threads = threads

    # --------------------------------------------------------------- messages
    def report(self, kind: str, text: str, source: SourceRef | None = None) -> None:
        self.reporter.emit(kind, text, source, self.simt)

    def note_once(self, key: str, text: str, source: SourceRef | None = None) -> None:
        """A note given only the first time ``key`` comes up."""
        if key not in self._noted:
            self._noted.add(key)
            self.report("note", text, source)

    # --------------------------------------------------------------- scenarios
    @property
    def scenario_name(self) -> str:
        """Name of the scenario (the first file loaded, or SCEN's name)."""
        return self.files.name

    def parse(self, text: str, path: str = "<scenario>", **kwargs: Any) -> ParsedScenario:
        """Parse scenario text against this simulation's command table."""
        from aamsim.plugins import plugin_providing

        def is_command(name: str) -> bool:
            return name in self.commands or plugin_providing(name) is not None

        return parse_scenario(text, path, is_command=is_command, **kwargs)

    def load_scenario(self, path: str | Path, *, text: str | None = None) -> ParsedScenario:
        """Queue a scenario file's commands (times are absolute). Errors are reported."""
        path = Path(path)
        if text is None:
            text = path.read_text(encoding="utf-8", errors="replace")
        parsed = self.parse(text, str(path))
        self.files.loaded(path, text)
        for err in parsed.errors:
            self.report("error", err.message, err.source)
        self.queue.extend(parsed.commands)
        return parsed

    def load_text(self, text: str, name: str = "<scenario>") -> ParsedScenario:
        """Queue scenario text (``HH:MM:SS>CMD`` lines)."""
        parsed = self.parse(text, name)
        for err in parsed.errors:
            self.report("error", err.message, err.source)
        self.queue.extend(parsed.commands)
        return parsed

    def find_file(self, name: str) -> Path | None:
        """Resolve a scenario file name (PCALL, IC) against the search path (and the files' guard)."""
        return self.files.find(name)

    # ---------------------------------------------------------------- commands
    @property
    def queue(self) -> CommandQueue:
        """Pending timed commands."""
        return self.scheduler.queue

    def stack(self, text: str, source: SourceRef | None = None) -> bool:
        """Execute command text now (``;`` separates commands). True if all succeeded.

        A failed command raises nothing: its reason is in ``sim.reporter.errors()`` (every message:
        ``sim.reporter.messages``) and goes to the ``aamsim`` logger (``logging.basicConfig()`` shows it).
        """
        return self.executor.stack(text, source)

    def schedule(self, time_s: float, text: str, source: SourceRef | None = None) -> None:
        """Queue command text for a sim time [s]."""
        self.executor.schedule(time_s, text, source)

    def execute(self, command: Command, source: SourceRef | None = None) -> bool:
        """Run one command through the command table; report any error."""
        return self.executor.execute(command, source)

    @property
    def current_source(self) -> SourceRef | None:
        """Source of the command being executed (for handlers that schedule more)."""
        return self.executor.source

    # ---------------------------------------------------------------- aircraft
    def create_aircraft(
        self,
        acid: str,
        actype: str,
        lat: float,
        lon: float,
        hdg: float = 0.0,
        alt: float = 0.0,
        spd: Speed | None = None,
        noncooperative: bool = False,
    ) -> int:
        """Create an aircraft (SI units); returns its slot.

        ``noncooperative``: real traffic replayed from a recording (:mod:`aamsim.realtraffic.replay`):
        the kernel flies it straight at the velocity the replay sets, without autopilot or
        envelope, and intents refuse it. The creation hooks see the flag already set.
        """
        acid = acid.upper()
        if acid in self._traffic:
            raise CommandError(f"aircraft {acid} already exists")
        if not acid or any(c in acid for c in " ,;#>'\""):
            raise CommandError(f'"{acid}" is not a valid callsign')
        if self.limits.room(self._traffic.n) == 0:
            raise CommandError(self.limits.refusal(
                f"{acid}: this simulation flies at most {self.limits.max_aircraft:,} aircraft at once, and "
                f"{self._traffic.n:,} fly at t = {self.simt:.2f} s: not created"))
        if len(acid) > MAX_CALLSIGN_CHARS:
            raise CommandError(f'"{acid[:20]}...": a callsign has at most {MAX_CALLSIGN_CHARS} characters, '
                               f"not {len(acid):,}")
        envelope, known = self.performance.lookup(actype)
        if not known and not noncooperative:
            self.note_once(
                f"type:{actype.upper()}",
                f"unknown aircraft type {actype.upper()}: using the {envelope.type_code} envelope",
                self.current_source,
            )
        spd = self._checked_creation(acid, lat, lon, alt, spd or Speed(0.0), envelope)
        self.executor.last_command[acid] = (self.executor.command_text or "create", self.executor.source)
        i = self._traffic.create(acid, actype, envelope, lat, lon, hdg, alt, spd or Speed(0.0), self.simt,
                                noncooperative)
        if self._wind.active and not noncooperative:
            intents.apply_wind_at_creation(self._traffic, i, self._wind)
        if self.state == self.STATE_INIT:
            self.state = self.STATE_OP
        self.scheduler.perf_pending = True
        self.hooks.created.call(self, i)
        return i

    def _checked_creation(self, acid: str, lat: float, lon: float, alt: float, spd: Speed, envelope: Any) -> Speed:
        """Refuse a position or altitude no aircraft can have; limit an absurd speed.

        A speed up to :data:`OVERSPEED_FACTOR` times the type's maximum is flown as in
        BlueSky: the performance model slows the aircraft at its deceleration. Beyond
        that it is a typo (1e6 kts flew at 513 km/s; 1e300 went NaN): it is limited to
        the type's maximum at once, with a warning.
        """
        if not (math.isfinite(lat) and -90.0 <= lat <= 90.0 and math.isfinite(lon)):
            raise CommandError(f"{acid}: position {lat}, {lon} is not on the earth (latitude -90..90)")
        if not (math.isfinite(alt) and MIN_ALTITUDE_FT * FT <= alt <= MAX_ALTITUDE_FT * FT):
            raise CommandError(f"{acid}: altitude {alt / FT:.6g} ft outside {MIN_ALTITUDE_FT:,.0f} .. "
                               f"{MAX_ALTITUDE_FT:,.0f} ft")
        if not math.isfinite(spd.value):
            raise CommandError(f"{acid}: speed {spd.value} is not a finite number")
        if spd.is_mach and spd.value > OVERSPEED_FACTOR * min(envelope.mmo, MAX_MACH):
            limit = min(envelope.mmo, MAX_MACH)
            self.report("warning", f"{acid}: Mach {spd.value:.6g} is more than {OVERSPEED_FACTOR:g} times the "
                                   f"{envelope.type_code}'s maximum {limit:g}: limited to it", self.current_source)
            return Speed(limit, is_mach=True)
        if not spd.is_mach and abs(spd.value) > OVERSPEED_FACTOR * envelope.vmax_mps:
            self.report("warning", f"{acid}: speed {spd.value / KTS:.6g} kts is more than {OVERSPEED_FACTOR:g} "
                                   f"times the {envelope.type_code}'s maximum {envelope.vmax_mps / KTS:.0f} kts CAS: "
                                   f"limited to it", self.current_source)
            return Speed(math.copysign(envelope.vmax_mps, spd.value))
        return spd

    def delete_aircraft(self, i: int, arrived: bool | None = None) -> FlightRecord:
        """Delete the aircraft in slot ``i``; closes and logs its flight record.

        ``arrived`` None means: arrived if within the arrival radius of its
        destination (DEST, else the last waypoint of its route).
        """
        record = self._traffic.flights[i]
        route = self._traffic.routes[i]
        if not record.destination and len(route):
            last = route.waypoints[-1]
            record.destination = last.name
            record.dest_lat, record.dest_lon = last.lat, last.lon
        if arrived is None:
            arrived = False
            if not math.isnan(record.dest_lat):
                _, dist = qdrdist(self._traffic.lat[i], self._traffic.lon[i], record.dest_lat, record.dest_lon)
                arrived = dist <= self.settings.arrival_radius_m
        record.arrived = bool(arrived)
        record.deleted_s = self.simt
        self.hooks.deleted.call(self, i, record)
        self.conditions.drop_aircraft(self._traffic.ids[i])
        self.executor.last_command.pop(self._traffic.ids[i], None)
        self._traffic.delete(i)
        self.flight_log.append(record)
        return record

    # ------------------------------------------------------------------ stepping
    def _run_due_commands(self) -> None:
        # Commands may queue more commands due now (SCHEDULE, PCALL, conditions).
        queue, clock = self.scheduler.queue, self._clock
        while True:
            due = queue.pop_due(clock.simt_us)
            if not due:
                return
            for k, cmd in enumerate(due):
                if self.quit_requested:
                    # QUIT, or a signal while a fan-out of PCALLs loads at one instant: stop here,
                    # the rest stays queued (a stop used to wait for every file to load).
                    queue.push_front(due[k:])
                    return
                self.executor.execute(cmd.command, cmd.source)

    def _boundary(self) -> None:
        """Everything that happens at the start of a step, at time simt."""
        # The scheduler's parts are called directly: this runs at every batch boundary
        # (about 10,000 times per episode of the corridor use case).
        scheduler, clock, hooks = self.scheduler, self._clock, self.hooks
        step_us = clock.dt_us  # the step that led here (a DT command below sets the next one)
        hooks.post_step.call_due(clock.simt_us, clock.dt_us, self)
        self._run_due_commands()
        if clock.simt_us >= scheduler.next_perf_us and scheduler.performance_due(self.settings.perf_interval_s,
                                                                                  step_us):
            # Fixed-wing limits follow the aircraft's state: the next refresh changes them again.
            scheduler.perf_pending = intents.refresh_performance(self._traffic)
        hooks.pre_step.call_due(clock.simt_us, clock.dt_us, self)
        if hooks.post_step.sleeping:
            # This boundary's commands may have changed what a sleeping hook watches: it must be
            # awake before the next event is looked for.
            hooks.post_step.wake_sleepers(clock.simt_us, self)

    def _advance_steps(self, nsteps: int) -> None:
        """Advance the traffic ``nsteps`` steps, handling events inside the batch."""
        done = 0
        check_first = True
        while done < nsteps:
            traffic = self._traffic
            n = traffic.n
            cond = self.conditions.arrays(traffic) if len(self.conditions) else _NO_CONDITIONS
            extra: tuple[int, ...] = ()
            kernel: Any = advance
            if self.threads > 1 and n >= PARALLEL_MIN_AIRCRAFT:
                numba.set_num_threads(self.threads)  # a per-thread setting: set it where the kernel runs
                kernel, extra = advance_parallel, (self.threads,)
            k, status = kernel(
                traffic.F,
                traffic.B,
                n,
                self._clock.dt_s,
                nsteps - done,
                check_first,
                self.settings.hold_speed_mps,
                self.settings.airborne_alt_m,
                traffic.scratch,
                cond,
                self._wind.arrays() if self._wind.active else None,
                () if traffic.turn_speeds_used else None,
                () if traffic.resolution_used else None,
                *extra,
            )
            done += k
            if status == STATUS_DONE:
                # The common end of a kernel call, with no event: no condition fired (the kernel returns
                # STATUS_CONDITION at once when one does), so there is only the clock to advance; done
                # here because a call of _after_kernel per kernel call (some 18,000 per corridor
                # episode) was a measurable part of its time.
                clock = self._clock
                clock.simt_us += k * clock.dt_us
                self.aircraft_steps += k * n
                check_first = True
                continue
            after = self._after_kernel(k, status, n, cond)
            if after == AFTER_BOUNDARY:
                return
            check_first = after == AFTER_CONTINUE
            if after == AFTER_LAST_STEP:
                nsteps = done + 1

    def _after_kernel(self, k: int, status: int, n: int, cond: tuple[np.ndarray, ...]) -> int:
        """Account for ``k`` kernel steps of ``n`` aircraft and handle the event that ended the call.

        Returns what the batch does next: ``AFTER_BOUNDARY`` (it ends: back to the step
        boundary), ``AFTER_CONTINUE`` (go on, waypoint test first), ``AFTER_TESTED`` (go on,
        the test for the next step already ran) or ``AFTER_LAST_STEP`` (as ``AFTER_TESTED``
        but the batch ends after the next step). :class:`aamsim.worlds.WorldSet` calls it
        for each of its simulations after a kernel call that stepped them together.
        """
        clock = self._clock
        clock.simt_us += k * clock.dt_us
        self.aircraft_steps += k * n
        if status == STATUS_NONFINITE:
            self._remove_non_finite()
            return AFTER_BOUNDARY
        if len(self.conditions) and k:
            fired = self.conditions.update_after(cond[3], cond[6])
            for c in fired:
                self.schedule(self.simt, c.command, c.source)
            if fired:
                return AFTER_BOUNDARY
        if status == STATUS_REACHED:
            # The test for the next step has run: finish this step without testing again.
            return AFTER_LAST_STEP if self._pass_waypoints() else AFTER_TESTED
        if status == STATUS_CONDITION:
            return AFTER_BOUNDARY
        return AFTER_CONTINUE

    def _remove_non_finite(self) -> None:
        """Delete aircraft whose state went non-finite, naming the last command that touched each.

        A NaN position would otherwise spread into conflict detection and the
        output files (a CRE speed of 1e300 once did, silently).
        """
        traffic = self._traffic
        for i in reversed(traffic.non_finite_slots()):
            acid = traffic.ids[i]
            state = traffic.describe_state(i)
            text, source = self.executor.last_command.get(acid, ("(none)", None))
            where = f"{source}: " if source is not None else ""
            self.report("error", f"{acid}: state not finite at t = {self.simt:.2f} s ({state}); last command on it: "
                                 f"{where}{text}; aircraft deleted", source)
            self.delete_aircraft(i, arrived=False)

    def _pass_waypoints(self) -> bool:
        """Start the next leg of every aircraft flagged by the kernel.

        Returns True when waypoint commands were queued or aircraft deleted,
        so that the batch ends after the current step.
        """
        traffic = self._traffic
        scratch_qdr, scratch_dist, fresh, reached_flags = traffic.scratch
        reached = np.flatnonzero(reached_flags[: traffic.n])
        side_effects = False
        # Highest slot first: deleting swaps the last aircraft into the freed slot.
        for i in reached[::-1]:
            i = int(i)
            fresh[i] = False  # its leg changed: guidance must be recomputed
            commands, was_last = pass_waypoint(traffic, i)
            acid = traffic.ids[i]
            for text, source in commands:
                self.schedule(self.simt + self.dt, text, source or SourceRef(f"AT {acid}", 0))
                side_effects = True
            if was_last and self.settings.delete_on_arrival:
                last = traffic.n - 1
                self.delete_aircraft(i, arrived=True)
                # The aircraft from the last slot now sits in slot i.
                fresh[i] = fresh[last] if i != last else False
                scratch_qdr[i] = scratch_qdr[last]
                scratch_dist[i] = scratch_dist[last]
                side_effects = True
        return side_effects

    def step(self) -> None:
        """Advance exactly one time step."""
        self.run_until(self.simt + self.dt)

    def step_bluesky(self) -> None:
        """One step as BlueSky's ``sim.step()`` takes it: what is due now, then one time step of the traffic.

        Unlike :meth:`step`, what falls due at the new time (commands, hooks, the
        performance refresh) waits for the next call, so that whatever the caller
        does between two calls (create an aircraft, run a command) happens before
        it, as in BlueSky. :mod:`aamsim.compat.bluesky` steps this way; a
        simulation should be stepped one way or the other, not both.
        """
        self._boundary()
        if self.state == self.STATE_HOLD or self.quit_requested:
            return
        self._advance_steps(1)

    def run_until(self, t_s: float, stop: Callable[[], bool] | None = None) -> None:
        """Advance until sim time ``t_s`` (a step boundary at or after it).

        ``stop``: asked after every step boundary (its commands and hooks done); True ends the run
        there, earlier. A caller waiting for something that only a command or a hook can do (an
        aircraft created) flies to it in one call instead of stopping at every time it might be there.
        """
        end_us = to_us(t_s)
        while True:
            self._boundary()
            if self.state == self.STATE_HOLD or self.quit_requested or self.simt_us >= end_us:
                return
            if stop is not None and stop():
                return
            self._advance_steps(self.scheduler.steps_to_next_event(end_us))

    def run(self, until_s: float | None = None, progress: Callable[[Simulation], None] | None = None,
            progress_interval_s: float = 60.0) -> None:
        """Run until ``until_s``, or without it until the scenario can change nothing more.

        Without ``until_s`` the run stops when nothing is left (no command
        pending, no conditional command waiting, no aircraft on a route), when
        nothing has progressed for an hour after the last command, or at the
        default horizon a day after it (:mod:`aamsim.run_end`, which says why
        in a note). :attr:`ended_by` names the reason: ``"until"``, ``"quit"``,
        ``"nothing_left"``, ``"no_progress"`` or ``"horizon"``.
        """
        from aamsim.run_end import OpenEndWatch

        watch = OpenEndWatch()
        chunk = min(progress_interval_s, 60.0)  # the open-ended checks come at least every minute
        self.ended_by = ""
        while True:
            target = self.simt + chunk
            if until_s is not None:
                target = min(target, until_s)
            self.run_until(target)
            if progress is not None:
                progress(self)
            if self.state == self.STATE_HOLD:
                self.note_once("hold", "HOLD: aamsim run has no operator to resume it; continuing")
                self.state = self.STATE_OP
            if self.quit_requested:
                self.ended_by = "quit"
                return
            if until_s is not None:
                if self.simt_us >= to_us(until_s):
                    self.ended_by = "until"
                    return
                continue
            stop = watch.check(self, chunk)
            if stop is not None:
                self.ended_by, message = stop
                if message:
                    self.report("note", message)
                return

    def is_quiescent(self) -> bool:
        """True when the scenario can produce no further change worth simulating."""
        if len(self.queue) or len(self.conditions) or any(pending() for pending in self.pending_work):
            return False
        if self._traffic.n == 0:
            return True
        view = self.view
        # Aircraft still following a route or changing speed/altitude keep the run going.
        return not (view.lnav.any() or view.vnav.any())

    def reset(self) -> None:
        """RESET: clear traffic, pending commands and time; keep plugins and hooks."""
        for i in range(self._traffic.n - 1, -1, -1):
            self.delete_aircraft(i, arrived=False)
        self.scheduler.reset()  # time 0, nothing pending; the step is kept
        self.files.reset_budget()
        self.conditions.clear()
        self.navdb.clear()
        self._wind.clear()
        self.state = self.STATE_INIT
        self.settings = SimSettings()
        self.hooks.reset.call(self)


_NO_CONDITIONS = (
    np.empty(0, dtype=np.int64),
    np.empty(0, dtype=np.int64),
    np.empty(0),
    np.empty(0),
    np.empty(0),
    np.empty(0),
    np.empty(0, dtype=np.bool_),
)


if TYPE_CHECKING:
    def _implements_command_context(sim: Simulation) -> CommandContext:
        return sim  # mypy checks here that a Simulation is everything a command handler may use


def iter_flights(sim: Simulation) -> Iterable[FlightRecord]:
    """Closed flights followed by the open ones (still flying); see :meth:`Simulation.flights`."""
    return sim.flights()
