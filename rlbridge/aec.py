"""PettingZoo AEC view of strategic planning: one planner agent per vertiport, requests one at a time.

:class:`StrategicPlanningAEC` runs the strategic planning use case
(:mod:`rlbridge.usecases.strategic`) with ``planners="vertiport"``: each origin
vertiport of the scenario's departure requests has its planner agent
(``planner_<ORIG>``; a request filed without ``ORIG`` goes to ``planner``).
Requests arrive one at a time, in filed order, so it is an AEC environment:
``agent_selection`` is the planner of the request now to be decided (the one
whose observation has valid actions in its ``action_mask``); the others observe
no request. Its reward per decision is the single planner's (delay,
unplaced, intent conflicts, and the NMAC and LoWC events until the next
decision); the other planners get 0. When the scenario is over every planner
is truncated (planners live for the whole episode).

It shares the engine of every other environment (:class:`rlbridge.core.EpisodeCore`
through :func:`rlbridge.backends.make_backend`), so it runs in process
(``backend="local"``) or in a simulation server (``backend="zmq"``) with the
same results::

    import rlbridge
    env = rlbridge.aec_env("nyc_train_100.scn")                       # StrategicPlanning, a planner per vertiport
    env = rlbridge.aec_env("nyc_train_100.scn", backend="zmq", address="tcp://127.0.0.1:5555")
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any, cast

import gymnasium as gym
import numpy as np
from pettingzoo import AECEnv

from rlbridge.backends import make_backend
from rlbridge.core import StepResult
from rlbridge.policies import make_usecase_with_policies
from rlbridge.usecases.strategic import StrategicPlanning

USECASE = "strategic_planning"


class StrategicPlanningAEC(AECEnv):
    """``aamgym/StrategicPlanning`` with one planner agent per vertiport (see the module docstring)."""

    metadata = {"name": "aamgym_strategic_planning_aec_v1", "render_modes": [], "is_parallelizable": False}  # noqa: RUF012

    def __init__(self, scenario: str | Path = "nyc_train_100.scn", backend: str = "local", address: str | None = None,
                 time_limit_s: float | None = None, dt: float = 0.05, timeout_s: float = 30.0, **params: Any):
        super().__init__()
        if params.get("planners", "vertiport") != "vertiport":
            raise ValueError("the AEC view has a planner per vertiport (planners='vertiport'); for one planner "
                             "use rlbridge.parallel_env or aamgym/StrategicPlanning-v1")
        params = {**params, "planners": "vertiport"}
        self._usecase = cast(StrategicPlanning, make_usecase_with_policies(USECASE, **params))
        self.core = make_backend(scenario, USECASE, params, backend, address, time_limit_s, dt, timeout_s)
        self.possible_agents: list[str] = list(self.core.possible_agents)
        self.agents: list[str] = []
        self.rewards: dict[str, float] = {}
        self._cumulative_rewards: dict[str, float] = {}
        self.terminations: dict[str, bool] = {}
        self.truncations: dict[str, bool] = {}
        self.infos: dict[str, dict[str, Any]] = {}
        self.agent_selection = self.possible_agents[0] if self.possible_agents else ""
        self._obs: dict[str, Any] = {}
        self.last_result: StepResult | None = None

    @functools.cache  # noqa: B019 (one per agent name, for the environment's life: PettingZoo wants the same object)
    def observation_space(self, agent: str) -> gym.Space:
        return self._usecase.observation_space()

    @functools.cache  # noqa: B019
    def action_space(self, agent: str) -> gym.Space:
        return self._usecase.action_space()

    def observe(self, agent: str) -> Any:
        return self._obs[agent]

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> None:
        result = self.core.reset(seed)
        self.agents = list(self.possible_agents)
        self.rewards = dict.fromkeys(self.agents, 0.0)
        self._cumulative_rewards = dict.fromkeys(self.agents, 0.0)
        self.terminations = dict.fromkeys(self.agents, False)
        self.truncations = dict.fromkeys(self.agents, False)
        self.infos = {a: {} for a in self.agents}
        self._take(result)

    def _take(self, result: StepResult) -> None:
        self.last_result = result
        infos = dict(zip(result.agents, result.infos()))
        for k, a in enumerate(result.agents):
            if a in self.terminations:
                self._obs[a] = result.obs.row(k)
                self.infos[a] = infos[a]
        if result.done:
            for k, a in enumerate(result.agents):
                if a in self.terminations:
                    self.terminations[a] = bool(result.terminated[k])
                    self.truncations[a] = not self.terminations[a]
            return
        deciding = [a for a in self.agents if self._has_request(self._obs[a])]
        if len(deciding) != 1:
            raise RuntimeError(f"{len(deciding)} planners have a request at {result.simt:g} s; expected one")
        self.agent_selection = deciding[0]

    def _has_request(self, obs: Any) -> bool:
        parts = obs if isinstance(obs, dict) else gym.spaces.unflatten(self._usecase.dict_space, obs)
        return bool(np.any(parts["action_mask"]))

    def step(self, action: Any) -> None:
        agent = self.agent_selection
        if self.terminations[agent] or self.truncations[agent]:
            self._was_dead_step(action)
            return
        self._cumulative_rewards[agent] = 0.0
        result = self.core.step({agent: int(action)})
        self.rewards = dict.fromkeys(self.agents, 0.0)
        for k, a in enumerate(result.agents):
            if a in self.rewards:
                self.rewards[a] = float(result.rewards[k])
        self._take(result)
        self._accumulate_rewards()

    def metrics(self) -> dict[str, Any]:
        """The episode's standard metrics and the planner's (as the other environments)."""
        return self.core.metrics()

    def close(self) -> None:
        self.core.close()


def aec_env(scenario: str | Path = "nyc_train_100.scn", **kwargs: Any) -> StrategicPlanningAEC:
    """Strategic planning as a PettingZoo ``AECEnv``, one planner per vertiport (:class:`StrategicPlanningAEC`)."""
    return StrategicPlanningAEC(scenario, **kwargs)
