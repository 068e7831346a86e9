"""Gymnasium and PettingZoo environments over an :class:`~rlbridge.core.EpisodeCore`, for any use case.

* :class:`AamParallelEnv` — PettingZoo ``ParallelEnv``: the use case's agents (for
  ``corridor_sa`` every airborne aircraft);
* :class:`AamSingleAgentEnv` — Gymnasium ``Env`` (``aamgym/<Name>-v1``, one id per use case;
  :class:`CorridorSAEnv` is ``aamgym/CorridorSA-v1``; ``-v0`` is the same on fixed traffic):
  one controlled agent among others that
  follow a chosen policy (default: no actions, e.g. unequipped aircraft).

Both run in-process (``backend="local"``), against a simulation server
(``backend="zmq", address="tcp://host:port"``) with identical results, or on
BlueSky itself (``backend="bluesky"``, :mod:`rlbridge.backends`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from pettingzoo import ParallelEnv

from aamsim.scenarios import resolve_scenario
from rlbridge.backends import make_backend
from rlbridge.core import EpisodeCore, StepResult, single_agent_watch
from rlbridge.policies import make_usecase_with_policies
from rlbridge.render import RENDER_FPS, RENDER_MODES, EnvRenderer, check_render_mode


class AamParallelEnv(ParallelEnv):
    """PettingZoo parallel environment over one use case (default ``corridor_sa``: every aircraft is an agent).

    Agents appear when created and leave (``terminations[a] = True``) when
    deleted, e.g. on arrival; the episode ends when the scenario is done or at
    ``time_limit_s`` (remaining agents truncated). Omitting an agent from the
    actions gives it no action this step (in ``corridor_sa`` it flies its
    flight plan: the unequipped baseline omits everyone). ``possible_agents``
    starts with the agents the scenario names and grows, before they appear,
    with those it creates otherwise (MCRE's random callsigns, PCALL, SCHEDULE).
    """

    metadata = {"name": "aamgym_corridor_sa_v1", "render_modes": list(RENDER_MODES), "render_fps": RENDER_FPS,
                "is_parallelizable": True}

    def __init__(
        self,
        scenario: str | Path = "nyc_train_100.scn",
        usecase: str | type = "corridor_sa",
        backend: str = "local",
        address: str | None = None,
        time_limit_s: float | None = None,
        dt: float = 0.05,
        timeout_s: float = 30.0,
        render_mode: str | None = None,
        render_size: tuple[int, int] = (640, 640),
        viewer_port: int = 0,
        threads: int | None = None,
        **params: Any,
    ):
        super().__init__()
        self.render_mode = check_render_mode(render_mode)
        self._usecase = make_usecase_with_policies(usecase, **params)
        version = getattr(type(self._usecase), "env_version", 1)
        self.metadata = {**self.metadata, "name": f"aamgym_{self._usecase.name}_v{version}"}
        self.core = make_backend(scenario, usecase, params, backend, address, time_limit_s, dt, timeout_s, threads)
        self.possible_agents: list[str] = list(self.core.possible_agents)
        self.agents: list[str] = []
        self._seed_rng = np.random.default_rng()
        self.last_result: StepResult | None = None
        self._renderer: EnvRenderer | None = None
        self._observation_spaces: dict[str, gym.Space[Any]] = {}
        self._action_spaces: dict[str, gym.Space[Any]] = {}
        if self.render_mode is not None:
            text = getattr(self.core, "text", None)
            if text is None:
                path = resolve_scenario(scenario)
                text = path.read_text(encoding="utf-8", errors="replace") if path is not None else ""
            self._renderer = EnvRenderer(self.core, text, self.render_mode, render_size, viewer_port)

    # Each agent's spaces are built on first use and kept on the instance (the same object on every
    # call); a functools.cache on the method, keyed by self, kept every env ever made alive.
    def observation_space(self, agent: str) -> gym.Space[Any]:
        if agent not in self._observation_spaces:
            self._observation_spaces[agent] = self._usecase.observation_space()
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> gym.Space[Any]:
        if agent not in self._action_spaces:
            self._action_spaces[agent] = self._usecase.action_space()
        return self._action_spaces[agent]

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        if seed is not None:
            self._seed_rng = np.random.default_rng(seed)
        episode_seed = int(self._seed_rng.integers(2**31 - 1)) if seed is None else int(seed)
        result = self.core.reset(episode_seed)
        self._take(result)
        obs = {a: result.obs.row(k) for k, a in enumerate(result.agents)}
        infos = dict(zip(result.agents, result.infos()))
        if self.render_mode == "human":
            self.render()
        return obs, infos

    def _until_alive(self, agent: str) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """Step an in-process episode without actions until ``agent`` is alive or the scenario is over,
        with nobody observed in between (its core watches ``agent`` only): the last step's observations
        and infos (:meth:`rlbridge.core.EpisodeCore.until_alive`)."""
        assert isinstance(self.core, EpisodeCore)
        result = self.core.until_alive(agent)
        self._take(result)
        return ({a: result.obs.row(k) for k, a in enumerate(result.agents)},
                dict(zip(result.agents, result.infos())))

    def _take(self, result: StepResult) -> None:
        self.last_result = result
        known = set(self.possible_agents)
        self.possible_agents += [a for a in result.discovered if a not in known]
        self.agents = list(result.alive)

    def step(self, actions: dict[str, Any]) -> tuple[dict[str, np.ndarray], dict[str, float], dict[str, bool],
                                                    dict[str, bool], dict[str, dict[str, Any]]]:
        result = self.core.step(actions)
        self._take(result)
        obs, rewards, terms, truncs = {}, {}, {}, {}
        infos = dict(zip(result.agents, result.infos()))
        for k, a in enumerate(result.agents):
            obs[a] = result.obs.row(k)
            rewards[a] = float(result.rewards[k])
            terms[a] = bool(result.terminated[k])
            truncs[a] = bool(result.truncated[k])
        if self.render_mode == "human":
            self.render()
        return obs, rewards, terms, truncs, infos

    def render(self) -> np.ndarray | None:
        """``rgb_array``: the traffic now as an RGB image; ``human``: show it in the web viewer (rlbridge.render)."""
        if self._renderer is None:
            return None  # PettingZoo's convention when no render_mode was chosen
        if self.last_result is None:
            raise RuntimeError("render() before reset()")
        if self.render_mode == "rgb_array":
            return self._renderer.rgb_array()
        self._renderer.show()
        return None

    def metrics(self) -> dict[str, Any]:
        """The episode's standard safety and operational metrics."""
        return self.core.metrics()

    def state(self) -> np.ndarray:
        raise NotImplementedError("no global state vector is defined for this use case")

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
        self.core.close()


def parallel_env(scenario: str | Path = "nyc_train_100.scn", **kwargs: Any) -> AamParallelEnv:
    """A use case (``usecase=``, default corridor separation assurance) as a PettingZoo ``ParallelEnv``."""
    return AamParallelEnv(scenario, **kwargs)


TrafficPolicy = Callable[[str, Any], int | None]


class AamSingleAgentEnv(gym.Env[np.ndarray, Any]):
    """Single-agent view of a use case: control one agent; the others follow ``traffic_policy``.

    ``ego`` is the controlled agent. Default (``ego=None``): each ``reset`` draws it from the agents
    the scenario names, with the reset's seed (so episodes differ in who is controlled, as well as in
    the use case's own draws); ``draw_ego=False`` takes the first agent the scenario names every time.
    The episode starts when the ego agent exists and ends when it
    leaves (terminated) or the scenario ends (truncated).
    ``traffic_policy(agent, obs) -> action or None`` drives the other agents;
    None (the default) gives them no action (in ``corridor_sa``: unequipped), and then nobody but
    the ego is observed or rewarded at each step (an in-process or BlueSky episode: the use cases'
    rows do not depend on which agents are asked with them, so the ego's are the same).
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": RENDER_FPS}

    def __init__(
        self,
        scenario: str | Path = "nyc_train_100.scn",
        ego: str | None = None,
        traffic_policy: TrafficPolicy | None = None,
        usecase: str | type = "corridor_sa",
        backend: str = "local",
        address: str | None = None,
        time_limit_s: float | None = None,
        dt: float = 0.05,
        timeout_s: float = 30.0,
        render_mode: str | None = None,
        render_size: tuple[int, int] = (640, 640),
        viewer_port: int = 0,
        draw_ego: bool = True,
        threads: int | None = None,
        **params: Any,
    ):
        self.render_mode = check_render_mode(render_mode)
        self._multi = AamParallelEnv(scenario, usecase, backend, address, time_limit_s, dt, timeout_s,
                                     render_mode=render_mode, render_size=render_size, viewer_port=viewer_port,
                                     threads=threads, **params)
        if not self._multi.possible_agents:
            raise ValueError(f"scenario {scenario} creates no aircraft")
        # The agents the scenario names (before any episode discovers more): where a drawn ego comes from.
        self._candidates = list(self._multi.possible_agents)
        self._draw_ego = ego is None and draw_ego
        ego = ego or self._candidates[0]
        # Callsigns are upper case; standing agents (a planner) keep their own names.
        self.ego = ego if ego in self._candidates else ego.upper()
        if self.ego not in self._candidates:
            raise ValueError(f"ego {self.ego} is not an agent the scenario names")
        self.traffic_policy = traffic_policy
        self.observation_space = self._multi.observation_space(self.ego)
        self.action_space = self._multi.action_space(self.ego)
        self._obs: dict[str, Any] = {}

    def _watch(self) -> None:
        """Observe only the ego when nothing else needs the others' observations (no traffic policy).

        A server episode (``backend="zmq"``) observes everybody, as before.
        """
        core = self._multi.core
        if isinstance(core, EpisodeCore):
            core.watch = single_agent_watch(self.ego, self.traffic_policy)

    def _traffic_actions(self) -> dict[str, Any]:
        if self.traffic_policy is None:
            return {}
        out = {}
        for a in self._multi.agents:
            if a != self.ego and a in self._obs:
                act = self.traffic_policy(a, self._obs[a])
                if act is not None:
                    out[a] = act
        return out

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        if self._draw_ego:
            self.ego = self._candidates[int(self.np_random.integers(len(self._candidates)))]
        self._watch()
        obs, infos = self._multi.reset(seed=seed)
        self._obs = obs
        core, last = self._multi.core, self._multi.last_result
        if isinstance(core, EpisodeCore) and core.watch is not None and self.render_mode != "human" \
                and self.ego not in self._multi.agents and last is not None and not last.done:
            # Nobody acts, is observed or is shown until the ego exists: fly there without the steps' reports
            # (as the native vector environment does; the ego's episode is the same).
            obs, infos = self._multi._until_alive(self.ego)
            self._obs = obs
        while self.ego not in self._multi.agents:
            if not self._multi.agents and self._multi.last_result is not None and self._multi.last_result.done:
                raise RuntimeError(f"the scenario ended before {self.ego} was created")
            obs, _, _, _, infos = self._multi.step(self._traffic_actions())
            self._obs = obs
        return obs[self.ego], infos.get(self.ego, {})

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self._watch()  # a traffic policy set since the reset: the others are observed from this step on
        actions = self._traffic_actions()
        actions[self.ego] = int(action) if isinstance(self.action_space, gym.spaces.Discrete) else action
        obs, rewards, terms, truncs, infos = self._multi.step(actions)
        self._obs = obs
        info = dict(infos.get(self.ego, {}))
        if self.ego not in obs:  # cannot happen: the ego is reported until it leaves
            raise RuntimeError(f"{self.ego} vanished from the episode")
        terminated = terms[self.ego]
        truncated = truncs[self.ego] or (not terminated and self.ego not in self._multi.agents)
        return obs[self.ego], rewards[self.ego], terminated, truncated, info

    def render(self) -> np.ndarray | None:  # type: ignore[override]  # an RGB array is gymnasium's RenderFrame
        """The whole traffic, as the parallel environment renders it (``rgb_array`` image or the web viewer)."""
        return self._multi.render()

    def close(self) -> None:
        self._multi.close()


class CorridorSAEnv(AamSingleAgentEnv):
    """``aamgym/CorridorSA-v1``: one aircraft of the corridor separation-assurance use case."""

    def __init__(self, scenario: str | Path = "nyc_train_100.scn", ego: str | None = None,
                 traffic_policy: TrafficPolicy | None = None, **kwargs: Any):
        kwargs.setdefault("usecase", "corridor_sa")
        super().__init__(scenario, ego, traffic_policy, **kwargs)
