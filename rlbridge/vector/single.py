"""``AamVectorEnv``: N single-agent episodes as one Gymnasium ``VectorEnv`` in one process.

``gymnasium.make_vec("aamgym/CorridorSA-v1", num_envs=16, vectorization_mode="vector_entry_point")``
(every use case whose agents are aircraft has the same entry point) builds it. Sub-environment
``i`` is exactly ``gymnasium.make("aamgym/CorridorSA-v1")`` reset with the same seed: the same
ego drawn from the scenario's agents, the same episode seed, observations, rewards,
terminations, truncations and infos (``tests/test_vector_env.py``). What differs is the
work: all sub-environments step in one :class:`~rlbridge.vector.engine.VectorEngine` (one
kernel call per batch for all of them) and only the egos are observed.

Autoreset follows Gymnasium 1.x: ``autoreset_mode="NextStep"`` by default, as
``gymnasium.vector.SyncVectorEnv`` (the step after a sub-environment ended resets it: its
action is ignored, its reward is 0, its termination and truncation False);
``"SameStep"`` resets it in the step that ended it (the final observation and info in
``infos["final_obs"]``/``infos["final_info"]``; what :func:`rlbridge.vector.sb3.to_sb3` uses).
A sub-environment whose episode ended never holds the others back.
"""

from __future__ import annotations

from collections.abc import Sequence
from copy import deepcopy
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from rlbridge.core import EpisodeCore, StepResult, single_agent_watch
from rlbridge.envs import TrafficPolicy
from rlbridge.vector.engine import Steps, VectorEngine, reset_request

SEED_BOUND = 2**31 - 1  # episode seeds drawn when reset gets none (as AamParallelEnv)


class _Episode:
    """One sub-environment's episode state: the ego, its generators (as AamSingleAgentEnv's)."""

    def __init__(self, core: EpisodeCore, ego: str | None, draw_ego: bool):
        self.core = core
        self.candidates = list(core.possible_agents)
        if not self.candidates:
            raise ValueError(f"scenario {core.path} creates no aircraft")
        self.draw_ego = ego is None and draw_ego
        ego = ego or self.candidates[0]
        self.ego = ego if ego in self.candidates else ego.upper()
        if self.ego not in self.candidates:
            raise ValueError(f"ego {self.ego} is not an agent the scenario names")
        self.np_random: np.random.Generator | None = None  # gymnasium.Env.np_random of the single env
        self.seed_rng = np.random.default_rng()  # AamParallelEnv's source of episode seeds
        self.obs: dict[str, Any] = {}  # last observation of every agent (for a traffic policy)
        self.result: StepResult | None = None


class AamVectorEnv(VectorEnv):
    """N sub-environments of ``AamSingleAgentEnv`` in one process (see the module docstring).

    Args:
        num_envs: sub-environments (at least 1).
        scenario: one scenario for all, or one per sub-environment.
        ego, traffic_policy, usecase, time_limit_s, dt, draw_ego, params: as
            :class:`rlbridge.envs.AamSingleAgentEnv` (the same for every sub-environment).
        threads: Numba threads stepping every sub-environment's aircraft (None: ``AAMSIM_THREADS``, else 1).
        autoreset_mode: ``"NextStep"`` (default) or ``"SameStep"`` (a :class:`gymnasium.vector.AutoresetMode`).
        copy: return copies of the observation arrays (as ``SyncVectorEnv``'s ``copy``).
    """

    def __init__(self, num_envs: int = 1, scenario: str | Path | Sequence[str | Path] = "nyc_train_100.scn",
                 ego: str | None = None, traffic_policy: TrafficPolicy | None = None, usecase: str = "corridor_sa",
                 time_limit_s: float | None = None, dt: float = 0.05, draw_ego: bool = True,
                 threads: int | None = None, autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
                 copy: bool = True, backend: str = "local", **params: Any):
        if backend != "local":
            raise ValueError(f"the vector environment runs its episodes in process (backend 'local'), not {backend!r}")
        mode = AutoresetMode(autoreset_mode)
        if mode == AutoresetMode.DISABLED:
            raise ValueError("autoreset_mode must be NextStep or SameStep")
        self.engine = VectorEngine(scenario, usecase, params, num_envs, time_limit_s, dt, threads)
        self.num_envs = num_envs
        self.autoreset_mode = mode
        self.metadata = {"autoreset_mode": mode, "render_modes": []}
        self.render_mode = None
        self.copy = copy
        self.traffic_policy = traffic_policy
        self.episodes = [_Episode(core, ego, draw_ego) for core in self.engine.cores]
        self.single_observation_space = self.engine.observation_space
        self.single_action_space = self.engine.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._discrete = isinstance(self.single_action_space, gym.spaces.Discrete)
        self._obs = _zeros(self.observation_space)
        self._rewards = np.zeros(num_envs, dtype=np.float64)
        self._terminations = np.zeros(num_envs, dtype=np.bool_)
        self._truncations = np.zeros(num_envs, dtype=np.bool_)
        self._autoreset = np.zeros(num_envs, dtype=np.bool_)

    # ---------------------------------------------------------------- episodes
    def _watch(self, ep: _Episode) -> None:
        ep.core.watch = single_agent_watch(ep.ego, self.traffic_policy)

    def _traffic_actions(self, ep: _Episode) -> dict[str, Any]:
        policy = self.traffic_policy
        if policy is None or ep.result is None:
            return {}
        out = {}
        for a in ep.result.alive:
            if a != ep.ego and a in ep.obs:
                act = policy(a, ep.obs[a])
                if act is not None:
                    out[a] = act
        return out

    def _take(self, ep: _Episode, result: StepResult) -> None:
        ep.result = result
        if self.traffic_policy is not None:
            ep.obs = {a: result.obs.row(k) for k, a in enumerate(result.agents)}

    def _reset_steps(self, ep: _Episode, seed: int | None) -> Steps:
        """AamSingleAgentEnv.reset as sim times to run to; returns the ego's observation and info."""
        if seed is not None or ep.np_random is None:
            ep.np_random, _ = seeding.np_random(seed)
        if ep.draw_ego:
            ep.ego = ep.candidates[int(ep.np_random.integers(len(ep.candidates)))]
        self._watch(ep)
        if seed is not None:
            ep.seed_rng = np.random.default_rng(seed)
        episode_seed = int(ep.seed_rng.integers(SEED_BOUND)) if seed is None else int(seed)
        result = yield from ep.core.reset_steps(episode_seed)
        self._take(ep, result)
        if self.traffic_policy is None and ep.ego not in result.alive and not result.done:
            # Nobody acts or is observed until the ego exists: fly there without the steps' reports.
            result = yield from ep.core.until_alive_steps(ep.ego)
        while ep.ego not in result.alive:
            if not result.alive and result.done:
                raise RuntimeError(f"the scenario ended before {ep.ego} was created")
            result = yield from ep.core.step_steps(self._traffic_actions(ep))
            self._take(ep, result)
        k = result.agents.index(ep.ego)
        return result.obs.row(k), result.infos()[k]

    def _step_steps(self, ep: _Episode, action: Any) -> Steps:
        """AamSingleAgentEnv.step as sim times to run to; returns obs, reward, terminated, truncated, info."""
        actions = self._traffic_actions(ep)
        actions[ep.ego] = int(action) if self._discrete else action
        result = yield from ep.core.step_steps(actions)
        self._take(ep, result)
        if ep.ego not in result.agents:  # cannot happen: the ego is reported until it leaves
            raise RuntimeError(f"{ep.ego} vanished from the episode")
        k = result.agents.index(ep.ego)
        terminated = bool(result.terminated[k])
        truncated = bool(result.truncated[k]) or (not terminated and ep.ego not in result.alive)
        return result.obs.row(k), float(result.rewards[k]), terminated, truncated, result.infos()[k]

    # --------------------------------------------------------------------- API
    def reset(self, *, seed: int | list[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        n = self.num_envs
        seeds, mask = reset_request(n, seed, options)
        worlds = np.flatnonzero(mask).tolist()
        out = self.engine.run({w: self._reset_steps(self.episodes[w], seeds[w]) for w in worlds})
        infos: dict[str, Any] = {}
        for w in worlds:
            obs, info = out[w]
            self._set_obs(w, obs)
            infos = self._add_info(infos, info, w)
        self._terminations[mask] = False
        self._truncations[mask] = False
        self._autoreset[mask] = False
        return self._observations(), infos

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        n = self.num_envs
        acts = np.asarray(actions) if self._discrete else actions
        if self._discrete and acts.shape != (n,):
            raise ValueError(f"expected {n} actions (one per sub-environment), got shape {acts.shape}")
        next_step = self.autoreset_mode == AutoresetMode.NEXT_STEP
        programs = {}
        for w, ep in enumerate(self.episodes):
            if next_step and self._autoreset[w]:
                programs[w] = self._reset_steps(ep, None)
            else:
                programs[w] = self._step_steps(ep, acts[w] if self._discrete else _row(actions, w))
        out = self.engine.run(programs)
        infos: dict[str, Any] = {}
        ended = []
        for w in range(n):
            if next_step and self._autoreset[w]:
                obs, info = out[w]
                self._rewards[w], self._terminations[w], self._truncations[w] = 0.0, False, False
            else:
                obs, self._rewards[w], self._terminations[w], self._truncations[w], info = out[w]
                if not next_step and (self._terminations[w] or self._truncations[w]):
                    infos = self._add_info(infos, {"final_obs": obs, "final_info": info}, w)
                    ended.append(w)
            self._set_obs(w, obs)
            if w not in ended:
                infos = self._add_info(infos, info, w)
        if ended:  # SameStep: the ended sub-environments start again now, together
            again = self.engine.run({w: self._reset_steps(self.episodes[w], None) for w in ended})
            for w in ended:
                obs, info = again[w]
                self._set_obs(w, obs)
                infos = self._add_info(infos, info, w)
        self._autoreset = self._terminations | self._truncations
        return (self._observations(), self._rewards.copy(), self._terminations.copy(), self._truncations.copy(),
                infos)

    def _set_obs(self, w: int, obs: Any) -> None:
        if isinstance(self._obs, dict):
            for name, arr in self._obs.items():
                arr[w] = obs[name]
        else:
            self._obs[w] = obs

    def _observations(self) -> Any:
        return deepcopy(self._obs) if self.copy else self._obs

    @property
    def egos(self) -> list[str]:
        """The agent each sub-environment controls in its current episode."""
        return [ep.ego for ep in self.episodes]

    def metrics(self, env: int) -> dict[str, Any]:
        """The standard safety and operational metrics of sub-environment ``env``'s current episode.

        For a use case with ``conflicts_of_agents_only`` the separation events (the safety figures)
        are those from the ego's creation on: the reset flies to it without conflict checks.
        """
        return self.engine.cores[env].metrics()

    def close_extras(self, **kwargs: Any) -> None:
        engine = getattr(self, "engine", None)  # None when the constructor refused its arguments
        if engine is not None:
            engine.close()


def _zeros(space: gym.Space) -> Any:
    if isinstance(space, gym.spaces.Dict):
        return {name: _zeros(sub) for name, sub in space.spaces.items()}
    assert space.shape is not None
    return np.zeros(space.shape, dtype=space.dtype)


def _row(actions: Any, w: int) -> Any:
    if isinstance(actions, dict):
        return {k: v[w] for k, v in actions.items()}
    return actions[w]


def make_vector_env(num_envs: int = 1, **kwargs: Any) -> AamVectorEnv:
    """The ``vector_entry_point`` of the ``aamgym/<Name>-v<N>`` ids (see the module docstring)."""
    return AamVectorEnv(num_envs=num_envs, **kwargs)
