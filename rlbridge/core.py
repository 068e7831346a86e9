"""The episode engine shared by every environment and the simulation server.

An :class:`EpisodeCore` runs one scenario with one use case: ``reset`` starts
the scenario and advances to the first moment an agent (an airborne aircraft)
exists; ``step`` applies the agents' actions, advances the simulation by the
use case's decision interval and returns arrays of observations, rewards,
terminations and flags for the agents. Agents appear when their aircraft is
created and leave (terminated) when it is deleted, e.g. on arrival. The local
backend calls it in-process; the ZMQ server calls the very same code, so both
backends give identical results.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from aamsim import Simulation
from aamsim.conflicts import conflicts_of
from aamsim.errors import SourceRef
from aamsim.metrics import metrics_of
from aamsim.scenarios import resolve_scenario
from aamsim.stack.parser import ParsedScenario, TimedCommand
from aamsim.stack.tokens import next_arg
from rlbridge.usecases.registry import Observations, UseCase, make_usecase

TRAFFIC_STATE_FIELDS = ("lat", "lon", "alt", "tas", "gs", "trk", "vs")
DEFAULT_EXTRA_TIME_S = 7200.0  # default episode limit: last scheduled command + 2 h


class ScenarioError(ValueError):
    """The scenario cannot be used (missing file, parse errors in strict mode)."""


@dataclass
class StepResult:
    """What one reset or step returns, as arrays over ``agents``.

    ``agents`` are the agents reported in this step: the ones alive before it,
    those that appeared during it, and those that left during it (terminated).
    ``alive`` lists the agents that continue (the environment's ``agents``).
    """

    agents: list[str]
    obs: Observations
    rewards: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    nmac: np.ndarray
    lowc: np.ndarray
    alive: list[str]
    simt: float
    done: bool
    info: dict[str, Any] = field(default_factory=dict)


def scenario_callsigns(parsed: ParsedScenario, registry_contains: Any) -> list[str]:
    """Callsigns created by CRE lines, in order of first creation (the possible agents)."""
    seen: dict[str, None] = {}
    for cmd in parsed.commands:
        name = cmd.command.name
        if name in ("CRE", "CREATE"):
            acid, _ = next_arg(cmd.command.argtext)
            if acid:
                seen.setdefault(acid.upper(), None)
    return list(seen)


class EpisodeCore:
    """One scenario, one use case, one simulation per episode."""

    def __init__(
        self,
        scenario: str | Path,
        usecase: str | UseCase = "corridor_sa",
        params: dict[str, Any] | None = None,
        time_limit_s: float | None = None,
        dt: float = 0.05,
        plugins: tuple[str, ...] = (),
        file_guard: Callable[[Path], None] | None = None,
    ):
        path = resolve_scenario(scenario)
        if path is None:
            raise ScenarioError(f"scenario not found: {scenario}")
        self.path = path
        self.text = path.read_text(encoding="utf-8", errors="replace")
        self.usecase: UseCase = make_usecase(usecase, **(params or {})) if isinstance(usecase, str) else usecase
        self.dt = dt
        self.plugins = tuple(plugins)
        self.file_guard = file_guard
        template = Simulation(use_bluesky_navdata=True)
        self._parsed = template.parse(self.text, str(path))
        self.parse_errors = [str(e) for e in self._parsed.errors]
        self.possible_agents = scenario_callsigns(self._parsed, template.commands.__contains__)
        last_command_s = max((c.time_s for c in self._parsed.commands), default=0.0)
        # Without a limit a policy that hovers would never end the episode.
        self.time_limit_s = time_limit_s if time_limit_s is not None else last_command_s + DEFAULT_EXTRA_TIME_S
        self.sim: Simulation | None = None
        self.agents: list[str] = []
        self.seed: int | None = None
        self._interval = float(self.usecase.params.decision_interval_s) \
            if hasattr(self.usecase, "params") else 10.0
        self._left: dict[str, dict[str, Any]] = {}

    # ----------------------------------------------------------------- helpers
    def _new_simulation(self, seed: int | None) -> Simulation:
        sim = Simulation(seed=seed, dt=self.dt)
        sim.scenario_name = self.path.stem
        sim.scenario_path = self.path
        sim.scenario_text = self.text
        sim.search_path.insert(0, self.path.parent)
        sim.file_guard = self.file_guard
        conflicts_of(sim)
        metrics_of(sim)
        self.usecase.attach(sim)
        from aamsim.plugins import load_plugin

        for name in self.plugins:
            load_plugin(sim, name)
        sim.hooks.deleted.add(self._on_deleted, name="episode.deleted")
        sim.queue.extend([TimedCommand(c.time_s, c.command, c.source) for c in self._parsed.commands])
        return sim

    def _on_deleted(self, sim: Simulation, slot: int, record: Any) -> None:
        acid = sim.traffic.ids[slot]
        if acid not in self.agents:
            return
        # Final observation and closest distance of a leaving agent, taken before it disappears.
        obs = self.usecase.observe(sim, [acid])
        closest = self.usecase.closest_distances(sim, [acid])
        self._left[acid] = {"obs": obs, "closest": float(closest[0]) if len(closest) else math.inf,
                            "arrived": bool(getattr(record, "arrived", False))}

    def _live_aircraft(self) -> list[str]:
        """Agents are the aircraft alive now, in order of first creation."""
        assert self.sim is not None
        alive = set(self.sim.traffic.ids)
        order = [a for a in self.agents if a in alive]
        known = set(order)
        order += [a for a in self.sim.traffic.ids if a not in known]
        return order

    def _scenario_over(self) -> bool:
        sim = self.sim
        assert sim is not None
        if sim.quit_requested:
            return True
        if self.time_limit_s is not None and sim.simt >= self.time_limit_s - 1e-9:
            return True
        return sim.is_quiescent()

    def _interval_events(self, t0: float) -> tuple[dict[str, float], set[str]]:
        """Per callsign, the smallest NMAC distance, and the LoWC set, over events overlapping [t0, now]."""
        assert self.sim is not None
        service = conflicts_of(self.sim)
        return service.involved_since("nmac", t0), set(service.involved_since("lowc", t0))

    def _advance(self) -> None:
        """Advance one decision interval; skip ahead while no agent is airborne."""
        sim = self.sim
        assert sim is not None
        while True:
            target = sim.simt + self._interval
            if self.time_limit_s is not None:
                target = min(target, self.time_limit_s)
            sim.run_until(target)
            if sim.state == sim.STATE_HOLD:
                sim.state = sim.STATE_OP  # no operator in an RL loop
            if sim.traffic.n > 0 or self._scenario_over():
                return

    # --------------------------------------------------------------------- API
    def reset(self, seed: int | None = None) -> StepResult:
        self.seed = seed
        self.agents = []
        self._left = {}
        self.sim = self._new_simulation(seed)
        self.sim.run_until(0.0)
        if self.sim.traffic.n == 0 and not self._scenario_over():
            self._advance()
        self.agents = self._live_aircraft()
        obs = self.usecase.observe(self.sim, self.agents)
        n = len(self.agents)
        done = self._scenario_over() and n == 0
        return StepResult(list(self.agents), obs, np.zeros(n), np.zeros(n, bool), np.zeros(n, bool),
                          np.zeros(n, bool), np.zeros(n, bool), list(self.agents), self.sim.simt, done)

    def step(self, actions: dict[str, Any]) -> StepResult:
        if self.sim is None:
            raise RuntimeError("step() before reset()")
        sim = self.sim
        before = list(self.agents)
        before_set = set(before)
        valid = {a: act for a, act in actions.items() if a in before_set}
        self.usecase.apply_actions(sim, valid)
        t0 = sim.simt
        self._left = {}
        self._advance()
        now_alive = self._live_aircraft()
        alive_set = set(now_alive)
        over = self._scenario_over()
        truncate = over and bool(now_alive)
        reported = before + [a for a in now_alive if a not in before_set]
        nmac_min, lowc_set = self._interval_events(t0)
        stay = [a for a in reported if a in alive_set]
        live_obs = self.usecase.observe(sim, stay) if stay else None
        live_closest = self.usecase.closest_distances(sim, stay) if stay else np.empty(0)
        # Assemble per reported agent: live ones from now, leaving ones from their capture.
        rows: list[Any] = []
        closest = np.empty(len(reported))
        terminated = np.zeros(len(reported), bool)
        index_live = {a: k for k, a in enumerate(stay)}
        for k, a in enumerate(reported):
            if a in index_live:
                rows.append(("live", index_live[a]))
                closest[k] = live_closest[index_live[a]]
            else:
                left = self._left.get(a)
                if left is None:  # deleted without capture (should not happen): zero observation
                    rows.append(("zero", 0))
                    closest[k] = math.inf
                else:
                    rows.append(("left", a))
                    closest[k] = left["closest"]
                terminated[k] = True
        obs = self._stack_obs(rows, live_obs)
        rewards = self.usecase.rewards(sim, reported, valid, closest, nmac_min)
        new_agents = set(reported) - before_set
        for k, a in enumerate(reported):
            if a in new_agents:
                rewards[k] = 0.0
        truncated = np.array([truncate and a in alive_set for a in reported], bool)
        nmac = np.array([a in nmac_min for a in reported], bool)
        lowc = np.array([a in lowc_set for a in reported], bool)
        self.agents = [] if truncate else [a for a in now_alive]
        done = over
        return StepResult(reported, obs, rewards, terminated, truncated, nmac, lowc, list(self.agents),
                          sim.simt, done)

    def _stack_obs(self, rows: list[tuple[str, Any]], live: Observations | None) -> Observations:
        space = self.usecase.observation_space()
        if hasattr(space, "spaces"):
            parts = {name: np.zeros((len(rows),) + sub.shape, dtype=sub.dtype) for name, sub in space.spaces.items()}
            for k, (kind, ref) in enumerate(rows):
                src = live if kind == "live" else (self._left[ref]["obs"] if kind == "left" else None)
                if src is None or src.parts is None:
                    continue
                j = ref if kind == "live" else 0
                for name in parts:
                    parts[name][k] = src.parts[name][j]
            return Observations(parts=parts)
        assert space.shape is not None
        flat = np.zeros((len(rows),) + space.shape, dtype=space.dtype)
        for k, (kind, ref) in enumerate(rows):
            if kind == "live":
                assert live is not None and live.flat is not None
                flat[k] = live.flat[ref]
            elif kind == "left":
                flat[k] = self._left[ref]["obs"].flat[0]
        return Observations(flat=flat)

    def metrics(self, groups: tuple[str, ...] = ("safety", "operational")) -> dict[str, Any]:
        """The episode's standard metrics so far (closes open events first when the episode is over)."""
        if self.sim is None:
            return {}
        if self._scenario_over():
            conflicts_of(self.sim).finish(self.sim)
        return metrics_of(self.sim).compute(self.sim, groups)

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
        t = self.sim.traffic
        state: dict[str, Any] = {"simt": self.sim.simt, "ids": list(t.ids[: t.n])}
        for name in TRAFFIC_STATE_FIELDS:
            state[name] = np.array(getattr(t, name), dtype=np.float64)
        return state

    def close(self) -> None:
        self.sim = None
        self.agents = []
