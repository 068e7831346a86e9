"""The episode engine shared by every environment and the simulation server.

An :class:`EpisodeCore` runs one scenario with one use case: ``reset`` starts
the scenario and advances to the first moment an agent exists; ``step`` applies
the agents' actions, advances the simulation to the use case's next decision
and returns arrays of observations, rewards, terminations and the use case's
per-agent info. Agents appear with the simulation's creation events (whatever
created the aircraft: CRE, MCRE, PCALL, SCHEDULE, a plugin) and leave
(terminated) with its deletion events, e.g. on arrival. The local
backend calls it in-process; the ZMQ server calls the very same code, so both
backends give identical results.

``reset`` and ``step`` are written as generators (:meth:`EpisodeCore.reset_steps`,
:meth:`EpisodeCore.step_steps`) that yield each sim time the simulation must be
run to: ``reset``/``step`` run them on the episode's own simulation, and the
vector engine (:mod:`rlbridge.vector`) runs the yields of many episodes together
on one :class:`~aamsim.worlds.WorldSet`, which gives each episode exactly what
it gives alone.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Generator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np

from aamsim import Simulation
from aamsim.errors import SourceRef
from aamsim.limits import SimulationLimits
from aamsim.scenarios import resolve_scenario
from aamsim.snapshots import SNAPSHOT_FIELDS, TrafficSnapshot, take_snapshot
from aamsim.stack.parser import ParsedScenario
from aamsim.stack.queue import to_us
from aamsim.stack.tokens import next_arg
from rlbridge.policies import make_usecase_with_policies
from rlbridge.usecases.protocol import Feedback, Observations, UseCase, check_feedback, empty_info
from rlbridge.usecases.spec import UseCaseSpec, spec_of
from rlbridge.usecases.targets import step_info

TRAFFIC_STATE_FIELDS = ("lat", "lon", "alt", "tas", "gs", "trk", "vs")
DEFAULT_EXTRA_TIME_S = 7200.0  # default episode limit: last scheduled command + 2 h
ADVANCE_CHUNK_S = 60.0  # a longer advance checks every this many seconds whether the scenario is over


class RunUntil(NamedTuple):
    """A yield of the step generators: run the simulation to ``t_s`` (as a plain time does), but end the
    run at the first step boundary where ``stop()`` is True (:meth:`aamsim.Simulation.run_until`)."""

    t_s: float
    stop: Callable[[], bool]


# What reset_steps/step_steps yield: the sim times [s] to run the simulation to (or a RunUntil), and
# finally the result.
Steps = Generator["float | RunUntil", None, "StepResult"]


class ScenarioError(ValueError):
    """The scenario cannot be used (missing file, parse errors in strict mode)."""


@dataclass
class StepResult:
    """What one reset or step returns, as arrays over ``agents``.

    ``agents`` are the agents reported in this step: the ones alive before it,
    those that appeared during it, and those that left during it (terminated).
    ``alive`` lists the agents that continue (the environment's ``agents``).
    ``agent_info`` holds the use case's per-agent info columns (its
    ``info_fields``: name -> array over ``agents``); ``discovered`` the agents
    that joined ``possible_agents`` during this call.
    """

    agents: list[str]
    obs: Observations
    rewards: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    alive: list[str]
    simt: float
    done: bool
    info: dict[str, Any] = field(default_factory=dict)
    agent_info: dict[str, np.ndarray] = field(default_factory=dict)
    discovered: list[str] = field(default_factory=list)

    def infos(self) -> list[dict[str, Any]]:
        """Each agent's info as plain Python values, with the sim time."""
        names = tuple(self.agent_info)
        simt = self.simt
        if not names:
            return [{"simt": simt} for _ in self.agents]
        rows = zip(*(col.tolist() for col in self.agent_info.values()))
        return [dict(zip(names, row), simt=simt) for row in rows]


def scenario_callsigns(parsed: ParsedScenario) -> list[str]:
    """Callsigns created by the scenario's own CRE lines, in order (the agents known before it runs).

    Aircraft created otherwise (MCRE, PCALL, SCHEDULE, plugins) join
    ``possible_agents`` when the simulation creates them.
    """
    seen: dict[str, None] = {}
    for cmd in parsed.commands:
        name = cmd.command.name
        if name in ("CRE", "CREATE"):
            acid, _ = next_arg(cmd.command.argtext)
            if acid:
                seen.setdefault(acid.upper(), None)
    return list(seen)


@dataclass
class _Leaving:
    """An agent's last observation and feedback, taken as its aircraft is deleted."""

    obs: Observations
    feedback: Feedback


def _alive_in_order(previous: list[str], live: Collection[str]) -> list[str]:
    """``live`` (in order of appearance): those in ``previous`` keep their order there, the others follow."""
    known = set(previous)
    return [a for a in previous if a in live] + [a for a in live if a not in known]


def single_agent_watch(ego: str, traffic_policy: object | None) -> tuple[str, ...] | None:
    """What a single-agent view has its episode observe (:attr:`EpisodeCore.watch`): its ego alone, unless a
    traffic policy drives the others from their observations (a use case's rows do not depend on which
    agents are asked with them, so the ego's are the same either way)."""
    return None if traffic_policy is not None else (ego,)


class EpisodeCore:
    """One scenario, one use case, one simulation per episode."""

    def __init__(
        self,
        scenario: str | Path,
        usecase: str | type | UseCase = "corridor_sa",
        params: dict[str, Any] | None = None,
        time_limit_s: float | None = None,
        dt: float = 0.05,
        plugins: tuple[str, ...] = (),
        file_guard: Callable[[Path], None] | None = None,
        limits: SimulationLimits | None = None,
        threads: int | None = None,
    ):
        path = resolve_scenario(scenario)
        if path is None:
            raise ScenarioError(f"scenario not found: {scenario}")
        self.path = path
        self.text = path.read_text(encoding="utf-8", errors="replace")
        self.usecase: UseCase = (make_usecase_with_policies(usecase, **(params or {})) if isinstance(usecase, (str, type))
                                 else usecase)
        self.spec: UseCaseSpec = spec_of(self.usecase)  # a use case without a spec is refused here
        self.dt = dt
        self.plugins = tuple(plugins)
        self.file_guard = file_guard
        self.limits = limits or SimulationLimits()  # a server's limits on each episode's simulation
        self.threads = threads
        # Makes each episode's simulation (keyword arguments of Simulation); the vector engine
        # replaces it to place the episode in its world set.
        self.make_simulation: Callable[..., Simulation] = Simulation
        # Agents whose observations and rewards are computed (None: every agent). A single-agent
        # view needs its ego's only; the others fly on unobserved (observing changes nothing).
        self.watch: Collection[str] | None = None
        # Whether until_alive_steps paused the conflict checks of this episode's simulation (until a
        # watched agent is created).
        self._checks_paused = False
        # Whether step results carry the heading/altitude action targets (rlbridge.usecases.targets):
        # set while an actor that reads them plays; a learner never does, and they cost a
        # computation per decision.
        self.publish_targets = False
        self._cut_at_limit: list[str] = []  # the agents the time limit cut at the episode's last step
        template = Simulation(use_bluesky_navdata=True)
        self._parsed = template.parse(self.text, str(path))
        self.parse_errors = [str(e) for e in self._parsed.errors]
        # A use case whose agents depend on the scenario (a planner per vertiport) reads it first.
        bind = getattr(self.usecase, "bind_scenario", None)
        if bind is not None:
            bind(list(self._parsed.commands), template.commands.__contains__)
        standing = list(self.usecase.standing_agents)
        # Aircraft named by CRE lines are known agents before the run, unless the use case's agents are not
        # aircraft (a planner).
        named = scenario_callsigns(self._parsed) if self.spec.aircraft_agents else []
        self.possible_agents: list[str] = standing + [a for a in named if a not in standing]
        self._possible = set(self.possible_agents)
        # Called with each episode's new simulation, before it runs (a recorder attaches here:
        # `aamgym evaluate video=true` writes the episode's run directory).
        self.on_new_simulation: list[Callable[[Simulation], None]] = []
        last_command_s = max((c.time_s for c in self._parsed.commands), default=0.0)
        # Without a limit a policy that hovers would never end the episode.
        self.time_limit_s = time_limit_s if time_limit_s is not None else last_command_s + DEFAULT_EXTRA_TIME_S
        self.sim: Simulation | None = None
        self.agents: list[str] = []
        self.seed: int | None = None
        self._live: dict[str, None] = {}  # agents alive now, in order of appearance
        # While _fly_idle runs: each change of _live as (sim time [us], agent, alive after it).
        self._live_log: list[tuple[int, str, bool]] | None = None
        self._reported: set[str] = set()  # agents alive at the last reset/step (their leaving is reported)
        self._discovered: list[str] = []
        self._left: dict[str, _Leaving] = {}
        self._actions: dict[str, Any] = {}
        self._t0 = 0.0

    # ----------------------------------------------------------------- helpers
    def _new_simulation(self, seed: int | None) -> Simulation:
        sim = self.make_simulation(seed=seed, dt=self.dt, threads=self.threads)
        sim.files.name = self.path.stem
        sim.files.path = self.path
        sim.files.text = self.text
        sim.files.search_path.insert(0, self.path.parent)
        sim.files.guard = self.file_guard
        sim.limits = self.limits  # before the use case attaches: its overlay parameters obey them too
        sim.services.start()
        self.usecase.attach(sim)
        from aamsim.plugins import load_plugin

        for name in self.plugins:
            load_plugin(sim, name)
        sim.hooks.created.add(self._on_created, name="episode.created")
        sim.hooks.deleted.add(self._on_deleted, name="episode.deleted")
        commands = list(self._parsed.commands)
        hold = getattr(self.usecase, "scenario_commands", None)  # a planner holds departures back
        if hold is not None:
            commands = hold(sim, commands)
        sim.queue.extend(commands)  # TimedCommand is frozen: the parsed ones are queued as they are
        for fn in self.on_new_simulation:
            fn(sim)
        return sim

    def _on_created(self, sim: Simulation, slot: int) -> None:
        agent = self.usecase.agent_of(sim, slot)
        if agent is None:
            return
        self._live[agent] = None
        if self._live_log is not None:
            self._live_log.append((sim.simt_us, agent, True))
        if self._checks_paused and self.watch is not None and agent in self.watch:
            self._resume_checks(sim)
        if agent not in self._possible:  # MCRE, PCALL, SCHEDULE, plugins: known only now
            self._possible.add(agent)
            self.possible_agents.append(agent)
            self._discovered.append(agent)

    def _on_deleted(self, sim: Simulation, slot: int, record: Any) -> None:
        agent = self.usecase.agent_of(sim, slot)
        if agent is None or agent not in self._live:
            return
        del self._live[agent]
        if self._live_log is not None:
            self._live_log.append((sim.simt_us, agent, False))
        if agent in self._reported:
            # Its final observation and feedback, taken before the aircraft disappears.
            self._left[agent] = _Leaving(self.usecase.observe(sim, [agent]),
                                         self.usecase.feedback(sim, [agent], self._actions, self._t0))

    def _live_agents(self) -> list[str]:
        """Agents alive now: those alive before keep their order, new ones follow in order of appearance."""
        return _alive_in_order(self.agents, self._live)

    def _scenario_over(self) -> bool:
        sim = self.sim
        assert sim is not None
        if sim.quit_requested:
            return True
        if self._at_time_limit(sim.simt):
            return True
        holding = getattr(self.usecase, "holding", None)  # departures a planner has still to release
        return sim.is_quiescent() and not (holding is not None and holding(sim))

    def _at_time_limit(self, t_s: float) -> bool:
        return self.time_limit_s is not None and t_s >= self.time_limit_s - 1e-9

    def _decision_target(self, due_s: float, simt: float, dt_s: float) -> float:
        """The time an advance from ``simt`` to a decision due at ``due_s`` runs to: a step at least, the
        episode's time limit at most (the first step boundary at or after it is the decision)."""
        target = max(due_s, simt + dt_s)
        return target if self.time_limit_s is None else min(target, self.time_limit_s)

    def _fly_to(self, target: float) -> Generator[float, None, None]:
        """Run to ``target`` (a decision), or until the scenario is over on the way."""
        sim = self.sim
        assert sim is not None
        # A long advance (a planner's last decision flies the rest of the episode) stops as soon as
        # the scenario is over instead of running an empty sky up to the time limit.
        while True:
            yield min(target, sim.simt + ADVANCE_CHUNK_S)
            if sim.state == sim.STATE_HOLD:
                sim.state = sim.STATE_OP  # no operator in an RL loop
            if sim.simt >= target - 1e-9 or self._scenario_over():
                return

    def _advance(self) -> None:
        """Advance to the use case's next decision; skip ahead while no agent is alive."""
        self._run(self._advance_steps())

    def _advance_steps(self) -> Generator[float, None, None]:
        """:meth:`_advance` as the sim times to run to (see the module docstring)."""
        sim = self.sim
        assert sim is not None
        while True:
            due = self.usecase.next_decision_s(sim)
            if due <= sim.simt and self._live and not self._scenario_over():
                return  # another decision due now (e.g. two departure requests at one time)
            yield from self._fly_to(self._decision_target(due, sim.simt, sim.dt))
            if self._live or self._scenario_over():
                return

    def _run(self, steps: Generator[float | RunUntil, None, Any]) -> Any:
        """Run ``steps`` on the episode's own simulation; returns what the generator returns."""
        try:
            t = next(steps)
            while True:
                assert self.sim is not None
                if type(t) is RunUntil:
                    self.sim.run_until(t.t_s, t.stop)
                else:
                    self.sim.run_until(t)  # type: ignore[arg-type]
                t = steps.send(None)
        except StopIteration as stop:
            return stop.value

    def _take_discovered(self) -> list[str]:
        out, self._discovered = self._discovered, []
        return out

    # --------------------------------------------------------------------- API
    def reset(self, seed: int | None = None) -> StepResult:
        return self._run(self.reset_steps(seed))  # type: ignore[no-any-return]

    def step(self, actions: dict[str, Any]) -> StepResult:
        if self.sim is None:
            raise RuntimeError("step() before reset()")
        return self._run(self.step_steps(actions))  # type: ignore[no-any-return]

    def until_alive(self, agent: str) -> StepResult:
        """:meth:`until_alive_steps` on the episode's own simulation: the step in which ``agent`` appeared."""
        return self._run(self.until_alive_steps(agent))  # type: ignore[no-any-return]

    def _watched(self, agents: list[str]) -> list[str]:
        watch = self.watch
        return agents if watch is None else [a for a in agents if a in watch]

    def reset_steps(self, seed: int | None = None) -> Steps:
        """:meth:`reset` as the sim times to run the new simulation to, then its result."""
        self.seed = seed
        self.agents = []
        self._reported = set()
        self._cut_at_limit = []
        self._left = {}
        self._live = dict.fromkeys(self.usecase.standing_agents)
        self._checks_paused = False  # a pause belonged to the simulation this reset replaces
        self.sim = self._new_simulation(seed)
        yield 0.0
        # Advance to the first decision: when an agent first exists, or a standing agent's first event.
        if (not self._live or self.usecase.standing_agents) and not self._scenario_over():
            yield from self._advance_steps()
        self.agents = self._live_agents()
        reported = self._watched(self.agents)
        self._reported = set(reported)
        obs = self.usecase.observe(self.sim, reported) if reported or self.watch is None else self._stack_obs([], None)
        n = len(reported)
        done = self._scenario_over() and not self.agents
        return StepResult(reported, obs, np.zeros(n), np.zeros(n, bool), np.zeros(n, bool),
                          list(self.agents), self.sim.simt, done,
                          info=self._target_info(self.sim),
                          agent_info=empty_info(self.usecase.info_fields, n), discovered=self._take_discovered())

    def step_steps(self, actions: dict[str, Any]) -> Steps:
        """:meth:`step` as the sim times to run the simulation to, then its result."""
        if self.sim is None:
            raise RuntimeError("step() before reset()")
        before, valid = self._begin_step(actions)
        yield from self._advance_steps()
        return self._finish_step(before, valid)

    def until_alive_steps(self, agent: str) -> Steps:
        """Steps without actions until ``agent`` is alive or the scenario is over; the last step's result.

        The same simulation as :meth:`step_steps` with no actions, one decision after the other,
        without observing anybody in between: for a single-agent view whose ego (``watch``) is not
        there yet (nobody is watched, so those steps would report nothing).

        When the use case reads only separation events that involve its agents
        (``conflicts_of_agents_only``), the conflict checks are left out until a watched agent is
        created (the conflict service is ``paused``): nothing watched can be in them. The watched
        agents' observations, rewards and infos are the same bit for bit; the episode's records
        (its events and the safety metrics from them) then begin at the ego's creation.

        When applying no actions changes nothing (the use case's ``idle_decisions_change_nothing``),
        the simulation is not stopped at each decision on the way (:meth:`_fly_idle`): the
        decisions are replayed, and the result is the same.
        """
        if self.sim is None:
            raise RuntimeError("step() before reset()")
        if self.watch is None or any(a in self.watch for a in self.agents):
            raise RuntimeError("until_alive_steps skips watched agents' steps")
        sim = self.sim
        if getattr(self.usecase, "conflicts_of_agents_only", False) and not sim.services.conflicts.paused:
            sim.services.conflicts.paused = self._checks_paused = True  # resumed by the watched agent's creation
        try:
            while True:
                before, valid = self._begin_step({})
                if self._may_fly_idle(sim):
                    yield from self._fly_idle(agent)
                else:
                    yield from self._advance_steps()
                if agent in self._live or self._scenario_over():
                    return self._finish_step(before, valid)
                self.agents = self._live_agents()
        finally:
            if self._checks_paused:  # the scenario ended first, or the generator was closed
                self._resume_checks(sim)

    # Whether until_alive_steps may fly to its agent without stopping at the decisions (_fly_idle). A
    # backend that does work at every decision (the BlueSky mirror) says False.
    flies_idle_decisions: bool = True
    FLY_IDLE_SPAN_US = 600_000_000  # how far (sim time) _fly_idle runs at most in one call

    def _may_fly_idle(self, sim: Simulation) -> bool:
        """Whether :meth:`_fly_idle` gives what :meth:`_advance_steps` gives from this decision on."""
        usecase = self.usecase
        idle = getattr(usecase, "idle_decisions_change_nothing", None)  # (a use case of the protocol alone)
        if not (self.flies_idle_decisions and idle is not None and idle(sim)):
            return False
        interval = usecase.decision_interval_s
        # The decisions come every interval, and one advance is one run (no ADVANCE_CHUNK_S stops:
        # their "scenario over" checks are not replayed). A pending command keeps the scenario from
        # being over until it runs (Simulation.is_quiescent). AUTODELETE deletes an aircraft at its
        # last waypoint, found by the kernel's test for the next step: on a decision, a run that
        # stops there finds it after the decision, one that goes on before it.
        return (0.0 < interval <= ADVANCE_CHUNK_S and usecase.next_decision_s(sim) == sim.simt + interval
                and len(sim.queue) > 0 and not sim.settings.delete_on_arrival)

    def _decision_after(self, g_us: int, interval_s: float, dt_s: float, dt_us: int) -> tuple[int, float]:
        """The decision :meth:`_advance_steps` reaches from the one at ``g_us``: its time [us], and the
        time [s] it runs to (the first step boundary at or after it is the decision)."""
        simt = g_us / 1_000_000  # as Simulation.simt
        target = self._decision_target(simt + interval_s, simt, dt_s)
        return g_us + max(0, -(-(to_us(target) - g_us) // dt_us)) * dt_us, target

    def _fly_idle(self, agent: str) -> Generator[float | RunUntil, None, None]:
        """:meth:`_advance_steps` for until_alive_steps's loop, without a stop at every decision.

        Called at a decision, right after ``_begin_step({})``, when :meth:`_may_fly_idle`. The
        simulation runs in one go to a decision some way ahead, and stops early at a step boundary
        where ``agent`` exists, no command is pending, the time step changed or AUTODELETE is on (a
        quit or a HOLD stops it too). Until then nothing that the loop looks at can change at a
        decision: ``agent`` is created by a command or a hook, at a step boundary; a pending command
        keeps the scenario from being over. The decisions flown past are replayed: the agents alive at each (from the
        creations and deletions logged with their times), the order ``self.agents`` takes and the
        last one with agents, where ``_begin_step`` would have set ``_t0``. ``_begin_step({})``
        there would apply nothing (the use case's ``idle_decisions_change_nothing``). Returns at
        the decision where the loop looks next (or at a quit, as _advance_steps does).
        """
        sim = self.sim
        assert sim is not None
        interval_s, dt_s, dt_us = self.usecase.decision_interval_s, sim.dt, sim.dt_us
        queue = sim.queue

        def stop() -> bool:
            return agent in self._live or not queue or sim.dt_us != dt_us or sim.settings.delete_on_arrival

        log: list[tuple[int, str, bool]] = []
        self._live_log = log
        try:
            while True:
                start_us = sim.simt_us
                live = dict(self._live)  # replayed through the log
                decisions: list[tuple[int, float]] = []
                g_us = start_us
                while g_us - start_us < self.FLY_IDLE_SPAN_US:
                    g_us, target = self._decision_after(g_us, interval_s, dt_s, dt_us)
                    decisions.append((g_us, target))
                    if self._at_time_limit(g_us / 1_000_000):
                        break  # the episode's end: the loop looks there
                log.clear()
                far_us = g_us
                while True:
                    yield RunUntil(far_us / 1_000_000, stop)
                    if sim.state == sim.STATE_HOLD:
                        sim.state = sim.STATE_OP  # no operator in an RL loop
                    if sim.simt_us >= far_us or sim.quit_requested or stop():
                        break
                now_us = sim.simt_us
                agents, t0_us, k = self.agents, -1, 0
                for g_us, target in decisions:
                    if g_us >= now_us:
                        break
                    while k < len(log) and log[k][0] <= g_us:
                        _, name, alive = log[k]
                        if alive:
                            live[name] = None
                        else:
                            del live[name]
                        k += 1
                    if live:  # _advance_steps returns here: the loop orders the agents and begins a step
                        agents, t0_us = _alive_in_order(agents, live), g_us
                self.agents = agents
                if t0_us >= 0:
                    self._t0 = t0_us / 1_000_000
                if sim.quit_requested:
                    return  # over now, as _advance_steps finds it
                if now_us < g_us:  # the rest of the way to the decision, as _advance_steps flies it
                    yield from self._fly_to(target)
                if self._live or self._scenario_over():
                    return
                if not self._may_fly_idle(sim):
                    break
        finally:
            self._live_log = None
        yield from self._advance_steps()

    def _resume_checks(self, sim: Simulation) -> None:
        sim.services.conflicts.paused = self._checks_paused = False

    def _begin_step(self, actions: dict[str, Any]) -> tuple[list[str], dict[str, Any]]:
        """Apply the actions of agents alive now; returns the watched agents before the step and the actions."""
        sim = self.sim
        assert sim is not None
        before_set = set(self.agents)
        valid = {a: act for a, act in actions.items() if a in before_set}
        self.usecase.apply_actions(sim, valid)
        self._actions, self._t0 = valid, sim.simt
        self._left = {}
        return self._watched(self.agents), valid

    def _finish_step(self, before: list[str], valid: dict[str, Any]) -> StepResult:
        """The step's result, after the simulation reached the next decision."""
        sim = self.sim
        assert sim is not None
        known = set(self.agents)
        now_alive = self._live_agents()
        alive_set = set(now_alive)
        over = self._scenario_over()
        truncate = over and bool(now_alive)
        watched_before = set(before)
        reported = before + [a for a in self._watched(now_alive) if a not in known]
        stay = [a for a in reported if a in alive_set]
        live_obs = self.usecase.observe(sim, stay) if stay else None
        live_fb = self.usecase.feedback(sim, stay, valid, self._t0)
        check_feedback(self.usecase, live_fb, len(stay))
        n = len(reported)
        if len(stay) == n:  # nobody left: the live arrays are the result (the common case)
            assert live_obs is not None or n == 0
            obs = self._conform(live_obs) if live_obs is not None else self._stack_obs([], None)
            rewards = np.array(live_fb.rewards, dtype=np.float64)
            info: dict[str, np.ndarray] = {name: np.array(live_fb.info[name], dtype=dtype)
                                           for name, dtype in self.usecase.info_fields.items()}
            terminated = np.zeros(n, bool)
        else:
            obs, rewards, info, terminated = self._assemble(reported, stay, live_obs, live_fb)
        for k, a in enumerate(reported):
            if a not in watched_before:  # an agent's first observation comes with no reward
                rewards[k] = 0.0
        truncated = np.array([truncate and a in alive_set for a in reported], bool)
        if truncate:
            self._cut_at_limit = [a for a, t in zip(reported, truncated) if t]
        self.agents = [] if truncate else list(now_alive)
        self._reported = set(self._watched(self.agents))
        return StepResult(reported, obs, rewards, terminated, truncated, list(self.agents), sim.simt, over,
                          info=self._target_info(sim), agent_info=info,
                          discovered=self._take_discovered())

    def _target_info(self, sim: Simulation) -> dict[str, Any]:
        """The step result's ``info``: the alive agents' action targets when asked (:attr:`publish_targets`),
        the departure planner's request for a departure-slot use case (rlbridge.usecases.targets)."""
        return step_info(self.usecase, sim, self.agents, targets=self.publish_targets)

    def _conform(self, obs: Observations) -> Observations:
        """The use case's observation arrays in its space's dtypes (no copy when they already are)."""
        space = self.usecase.observation_space()
        if obs.parts is not None and isinstance(space, gym.spaces.Dict):
            return Observations(parts={name: np.asarray(obs.parts[name], dtype=sub.dtype)
                                       for name, sub in space.spaces.items()})
        assert obs.flat is not None
        return Observations(flat=np.asarray(obs.flat, dtype=space.dtype))

    def _assemble(self, reported: list[str], stay: list[str], live_obs: Observations | None,
                  live_fb: Feedback) -> tuple[Observations, np.ndarray, dict[str, np.ndarray], np.ndarray]:
        """Per reported agent: live ones from now (one gather), leaving ones from their capture."""
        rows: list[Any] = []
        n = len(reported)
        info = empty_info(self.usecase.info_fields, n)
        terminated = np.zeros(n, bool)
        index_live = {a: k for k, a in enumerate(stay)}
        live_k = np.fromiter((k for k, a in enumerate(reported) if a in index_live), dtype=np.int64)
        rewards = np.zeros(n)
        rewards[live_k] = live_fb.rewards
        for name, col in info.items():
            col[live_k] = live_fb.info[name]
        for k, a in enumerate(reported):
            j = index_live.get(a)
            if j is not None:
                rows.append(("live", j))
                continue
            terminated[k] = True
            left = self._left.get(a)
            if left is None:  # deleted without capture (should not happen): zero observation
                rows.append(("zero", 0))
                continue
            rows.append(("left", a))
            rewards[k] = left.feedback.rewards[0]
            for name, col in info.items():
                col[k] = left.feedback.info[name][0]
        return self._stack_obs(rows, live_obs), rewards, info, terminated

    def _stack_obs(self, rows: list[tuple[str, Any]], live: Observations | None) -> Observations:
        space = self.usecase.observation_space()
        if isinstance(space, gym.spaces.Dict):
            parts = {name: np.zeros((len(rows), *(sub.shape or ())), dtype=sub.dtype)
                     for name, sub in space.spaces.items()}
            for k, (kind, ref) in enumerate(rows):
                src = live if kind == "live" else (self._left[ref].obs if kind == "left" else None)
                if src is None or src.parts is None:
                    continue
                j = ref if kind == "live" else 0
                for name, arr in parts.items():
                    arr[k] = src.parts[name][j]
            return Observations(parts=parts)
        assert space.shape is not None
        flat = np.zeros((len(rows),) + space.shape, dtype=space.dtype)
        for k, (kind, ref) in enumerate(rows):
            if kind == "live":
                assert live is not None and live.flat is not None
                flat[k] = live.flat[ref]
            elif kind == "left":
                left = self._left[ref].obs.flat
                assert left is not None
                flat[k] = left[0]
        return Observations(flat=flat)

    def metrics(self, groups: tuple[str, ...] = ("safety", "operational")) -> dict[str, Any]:
        """The episode's standard metrics so far (closes open events first when the episode is over)."""
        if self.sim is None:
            return {}
        if self._scenario_over():
            self.sim.services.conflicts.finish(self.sim)
        out = self.sim.services.metrics.compute(self.sim, groups)
        if "operational" in out:
            out["operational"].update(self._time_limit_counts())
        extra = self.usecase.extra_metrics(self.sim)
        undeclared = sorted(set(extra) - set(self.spec.metrics))
        if undeclared:
            raise ValueError(f"use case {self.usecase.name}: extra_metrics gave {', '.join(undeclared)}, which its "
                             f"spec does not declare (UseCaseSpec.metrics: {', '.join(self.spec.metrics) or 'none'})")
        if extra:
            out[self.usecase.name] = extra
        return out

    def _time_limit_counts(self) -> dict[str, int]:
        """Aircraft still flying when the time limit cut the episode, and of them those hovering.

        ``parked_at_time_limit`` counts the aircraft cut by the limit with a ground speed under the
        simulation's holding threshold (``hold_speed_mps``, 5 kt): a policy that parks aircraft in
        the air rather than resolve a conflict leaves them there (the corridor use case's "hold"
        keeps 0 kt for free). Computed where the simulation runs, so a ZeroMQ client gets them too;
        agents without an aircraft (a departure planner) are not counted. Both 0 before the end.
        """
        assert self.sim is not None
        view = self.sim.view
        slots = [slot for slot in (view.find(a) for a in self._cut_at_limit) if slot is not None]
        threshold = float(self.sim.settings.hold_speed_mps)
        parked = sum(1 for slot in slots if abs(float(view.gs[slot])) < threshold)
        return {"airborne_at_time_limit": len(slots), "parked_at_time_limit": parked}

    def stack(self, text: str) -> list[str]:
        """Run stack commands now; returns the messages they produced."""
        if self.sim is None:
            raise RuntimeError("stack() before reset()")
        start = len(self.sim.reporter.messages)
        self.sim.stack(text, SourceRef("<bridge>"))
        return [str(m) for m in self.sim.reporter.since(start)]

    def traffic_state(self) -> dict[str, Any]:
        """The aircraft now flying: ``ids`` and SI arrays (deg, m, m/s) ``lat lon alt tas gs trk vs``."""
        if self.sim is None:
            raise RuntimeError("traffic_state() before reset()")
        return self.sim.services.snapshots.latest().as_dict(TRAFFIC_STATE_FIELDS)

    def snapshot(self, fields: tuple[str, ...] = SNAPSHOT_FIELDS) -> TrafficSnapshot:
        """A frozen copy of the traffic now (the fields' SI arrays): what a policy reads besides its observations."""
        if self.sim is None:
            raise RuntimeError("snapshot() before reset()")
        # With the separation standard now: the baselines' protected zones follow the simulation's.
        return take_snapshot(self.sim, fields, self.sim.separation_standard)

    def close(self) -> None:
        self.sim = None
        self.agents = []
