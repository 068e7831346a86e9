"""Hierarchical AAM services: strategic planning (macro) and tactical separation (micro) in one episode.

The paper's joint study ("how different AAM services interact once
deployed"): a departure planner (:mod:`rlbridge.usecases.strategic`) releases
the scenario's flights, and a tactical layer gives them speed advisories as
they fly (:mod:`rlbridge.usecases.corridor`'s observation and actions). One
level learns while the other is frozen (``train``):

* ``train="planner"`` — the agent is the planner (the strategic use case's
  observation, actions and reward); the tactical layer is ``tactical``: a
  speed baseline (``mvp_speed``, ``unequipped``; ``daa`` once the baseline
  registry has it) or a trained corridor policy (a training run or checkpoint);
* ``train="tactical"`` — every aircraft is an agent (the corridor use case's
  observation, actions and reward, its altitude noise too); the planner is
  ``planner``: ``fcfs``, ``no_planning`` or a trained planner (a training run
  or checkpoint of ``strategic_planning``), deciding each request at its time.

The episode's metrics hold both levels: the standard safety and operational
groups (advisories, alerts, holding) and the planner's (delays, unplaced
requests, throughput) under ``hierarchical``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, ClassVar

import gymnasium as gym
import numpy as np

from aamsim.stack.parser import TimedCommand
from rlbridge.usecases.corridor import CorridorSA
from rlbridge.usecases.frozen import NO_POLICY, FrozenPolicy, PolicySource, SimHandle, frozen_policy
from rlbridge.usecases.protocol import Feedback, Observations, UseCaseBase, check_advisory_kinds, make_params
from rlbridge.usecases.spec import SEPARATION_CURVE, CurveColumn, UseCaseSpec
from rlbridge.usecases.strategic import PLANNER, PLANNING_METRICS, StrategicPlanning
from rlbridge.usecases.tactical import PLANNER_BASELINES

if TYPE_CHECKING:
    from aamsim import Simulation

FAR_S = 365 * 86400.0  # "no further request": a hook interval that never comes due


@dataclass(frozen=True)
class HierarchicalParams:
    train: str = "planner"  # the level that learns: "planner" or "tactical"
    planner: str = "fcfs"  # the frozen planner when train="tactical"
    tactical: str = "mvp_speed"  # the frozen tactical layer when train="planner"
    planning: dict[str, Any] = field(default_factory=dict)  # strategic_planning parameters
    corridor: dict[str, Any] = field(default_factory=dict)  # corridor_sa parameters
    obs_format: str | None = None  # of the level that learns (None: its default)

    def __post_init__(self) -> None:
        if self.train not in ("planner", "tactical"):
            raise ValueError(f"train must be 'planner' or 'tactical', not {self.train!r}")
        for name in ("planning", "corridor"):
            if "obs_format" in getattr(self, name) or "tactical" in getattr(self, name):
                raise ValueError(f"set obs_format and tactical on the hierarchical use case, not in {name}")


class Hierarchical(UseCaseBase):
    """``hierarchical`` (``aamgym/Hierarchical-v1``): see the module docstring."""

    name = "hierarchical"
    env_name = "Hierarchical"
    # The class's spec is that of its default level (train="planner": the strategic planner's, plus its
    # own metrics); an instance with train="tactical" has the corridor level's actions and baselines.
    spec = UseCaseSpec(HierarchicalParams, action_kinds=StrategicPlanning.spec.action_kinds,
                       baselines=StrategicPlanning.spec.baselines, advisory="tactical_layer",
                       metrics=("train", "planner", "tactical", *PLANNING_METRICS), aircraft_agents=False,
                       plans_departures=True, policy_params=("tactical", "planner"),
                       curve=(CurveColumn("mean_delay_s", "hierarchical.mean_delay_s", per_aircraft=False),
                              CurveColumn("unplaced_per_aircraft", "hierarchical.unplaced"),
                              *SEPARATION_CURVE))
    # Both levels draw the paper's altitude noise by default; fixed traffic switches both off.
    fixed_traffic: ClassVar[dict[str, Any]] = {"planning": {"alt_noise_ft": 0.0}, "corridor": {"alt_noise_ft": 0.0}}

    def __init__(self, policies: PolicySource | None = None, **params: Any):
        """``policies``: builds the frozen planner and tactical layer (rlbridge.usecases.frozen)."""
        self.params: HierarchicalParams = make_params(HierarchicalParams, params)
        p = self.params
        fmt = {"obs_format": p.obs_format} if p.obs_format else {}
        self.planner_policy: FrozenPolicy | None = None
        self.corridor: CorridorSA | None = None
        if p.train == "planner":
            self.planning = StrategicPlanning(policies, **{**p.planning, "tactical": p.tactical, **fmt})
            self.standing_agents = (PLANNER,)
            self.info_fields = dict(self.planning.info_fields)
        else:
            policy = frozen_policy(p.planner, "planner", (NO_POLICY, *PLANNER_BASELINES), policies)
            if policy.usecase not in (None, "strategic_planning"):
                raise ValueError(f"planner {p.planner!r} was trained on {policy.usecase}, not strategic_planning")
            trained = {k: v for k, v in policy.usecase_params.items() if k != "tactical"}
            self.planning = StrategicPlanning(policies, **{**trained, **p.planning,
                                                 "obs_format": policy.obs_format or "dict"})
            self.planner_policy = policy
            self.corridor = CorridorSA(**{**p.corridor, **fmt})
            self.standing_agents = ()
            self.info_fields = dict(self.corridor.info_fields)
            level = self.corridor.spec  # the aircraft's speed actions, advisories and baselines
            self.spec = replace(Hierarchical.spec, action_kinds=level.action_kinds, speed_actions=level.speed_actions,
                                baselines=level.baselines, advisory=level.advisory, aircraft_agents=True)
        self._rng = np.random.default_rng(0)
        self._handle: SimHandle | None = None

    def departure_planner(self) -> StrategicPlanning:
        """The planner that decides departure slots (what the planner baselines steer): its planning level."""
        return self.planning

    @property
    def level(self) -> Any:
        """The use case of the level that learns."""
        return self.planning if self.corridor is None else self.corridor

    @property
    def decision_interval_s(self) -> float:
        return float(self.level.decision_interval_s)

    def observation_space(self) -> gym.Space:
        return self.level.observation_space()

    def action_space(self) -> gym.Space:
        return self.level.action_space()

    # -------------------------------------------------------------- lifecycle
    def attach(self, sim: Simulation) -> None:
        self.planning.attach(sim)  # volumes, planned layers, the frozen tactical layer (train="planner")
        if self.corridor is None:
            return
        self.corridor.attach(sim)  # its volumes and altitude noise
        self._rng = np.random.default_rng(np.random.SeedSequence([0 if sim.seed is None else int(sim.seed), 0x91A]))
        self._handle = SimHandle(sim, sim.seed, self.planning)
        sim.hooks.pre_step.add(self._plan_due, interval_s=lambda: self._to_next_request(sim), name="hier.planner",
                               priority=40)

    def scenario_commands(self, sim: Simulation, commands: list[TimedCommand]) -> list[TimedCommand]:
        return self.planning.scenario_commands(sim, commands)

    def holding(self, sim: Simulation) -> bool:
        return self.planning.holding(sim)

    def agent_of(self, sim: Simulation, slot: int) -> str | None:
        return None if self.corridor is None else sim.view.ids[slot]

    def next_decision_s(self, sim: Simulation) -> float:
        if self.corridor is None:
            return self.planning.next_decision_s(sim)
        return sim.simt + self.corridor.decision_interval_s

    # ------------------------------------------------ the frozen planner (train="tactical")
    def _to_next_request(self, sim: Simulation) -> float:
        if self.planning.plan is None:
            return sim.dt
        due = self.planning.next_decision_s(sim)
        return FAR_S if due == float("inf") else max(due - sim.simt, sim.dt)

    def _plan_due(self, sim: Simulation) -> None:
        """Decide every request due by the next step (one step ahead, as the planner agent does)."""
        assert self.planner_policy is not None and self._handle is not None
        while (req := self.planning.current()) is not None and req.request_s - sim.dt <= sim.simt + 1e-9:
            obs = self.planning.observe(sim, [PLANNER])
            action = self.planner_policy.act(self._handle, [PLANNER], obs, self._rng)
            chosen = {} if action is None or action[0] < 0 else {PLANNER: int(action[0])}
            self.planning.apply_actions(sim, chosen)

    # ------------------------------------------------------- the learning level
    def observe(self, sim: Simulation, agents: list[str]) -> Observations:
        return self.level.observe(sim, agents)

    def speed_action_targets(self, sim: Simulation, slots: np.ndarray) -> np.ndarray:
        """The corridor level's speed targets (``train=tactical``; the planner selects no speeds)."""
        if self.corridor is None:
            check_advisory_kinds(self, ("speed",), "a speed-advisory policy")
        assert self.corridor is not None
        return self.corridor.speed_action_targets(sim, slots)

    def apply_actions(self, sim: Simulation, actions: dict[str, Any]) -> None:
        self.level.apply_actions(sim, actions)

    def feedback(self, sim: Simulation, agents: list[str], actions: dict[str, Any], since_s: float) -> Feedback:
        fb: Feedback = self.level.feedback(sim, agents, actions, since_s)
        return fb

    def extra_metrics(self, sim: Simulation) -> dict[str, Any]:
        out: dict[str, Any] = {"train": self.params.train,
                               "planner": self.params.planner if self.corridor else "agent",
                               "tactical": self.params.tactical if self.corridor is None else "agents"}
        out.update(self.planning.extra_metrics(sim))
        if self.corridor is not None:
            out["tactical_decisions"] = None  # the agents' decisions are the episode's transitions
        return out
