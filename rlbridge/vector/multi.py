"""``AamParallelVectorEnv``: N PettingZoo-style multi-agent episodes in one process, stepped together.

Sub-environment ``i`` is exactly ``rlbridge.parallel_env(...)`` reset with the same seed
(``tests/test_vector_env.py``): the same agents appearing and leaving, observations, rewards,
terminations, truncations and infos, as dictionaries per sub-environment (:meth:`reset`,
:meth:`step`), or as the engine's arrays (:meth:`step_results`: one
:class:`~rlbridge.core.StepResult` per sub-environment, what the rollout workers use). All
sub-environments run on one :class:`~rlbridge.vector.engine.VectorEngine`.

There is no autoreset: a sub-environment whose episode is over (no agents left) is skipped
by :meth:`step` (no actions needed) until it is reset (``reset(options={"reset_mask": ...})``
starts chosen ones again), and it never holds the others back.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from rlbridge.core import StepResult
from rlbridge.vector.engine import VectorEngine, reset_request

SEED_BOUND = 2**31 - 1


class AamParallelVectorEnv:
    """N ``AamParallelEnv`` episodes of one use case (see the module docstring).

    Args:
        num_envs: sub-environments (at least 1).
        scenario: one scenario for all, or one per sub-environment.
        usecase, time_limit_s, dt, params: as :class:`rlbridge.envs.AamParallelEnv`.
        threads: Numba threads stepping every sub-environment's aircraft (None: ``AAMSIM_THREADS``, else 1).
    """

    metadata: ClassVar[dict[str, Any]] = {"name": "aamgym_parallel_vector", "is_parallelizable": True}

    def __init__(self, num_envs: int = 1, scenario: str | Path | Sequence[str | Path] = "nyc_train_100.scn",
                 usecase: str = "corridor_sa", time_limit_s: float | None = None, dt: float = 0.05,
                 threads: int | None = None, **params: Any):
        self.engine = VectorEngine(scenario, usecase, params, num_envs, time_limit_s, dt, threads)
        self.num_envs = num_envs
        self.possible_agents: list[list[str]] = [list(c.possible_agents) for c in self.engine.cores]
        self.agents: list[list[str]] = [[] for _ in range(num_envs)]
        self._seed_rngs = [np.random.default_rng() for _ in range(num_envs)]
        self.last_results: list[StepResult | None] = [None] * num_envs

    @property
    def cores(self) -> list[Any]:
        """The episode engines (:class:`~rlbridge.core.EpisodeCore`), one per sub-environment."""
        return self.engine.cores

    def observation_space(self, agent: str) -> gym.Space:
        return self.engine.observation_space

    def action_space(self, agent: str) -> gym.Space:
        return self.engine.action_space

    # --------------------------------------------------------------- arrays
    def reset_results(self, seed: int | Sequence[int | None] | None = None,
                      options: dict[str, Any] | None = None) -> dict[int, StepResult]:
        """Start new episodes (all, or those of ``options["reset_mask"]``); the engine's results by sub-environment.

        ``seed``: None (each draws from its own generator, as ``AamParallelEnv``), an int (sub-environment
        ``i`` gets ``seed + i``, as Gymnasium's vector environments) or one per sub-environment.
        """
        n = self.num_envs
        seeds, mask = reset_request(n, seed, options)
        episode_seeds: dict[int, int] = {}
        for w in np.flatnonzero(mask).tolist():
            given = seeds[w]
            if given is not None:
                self._seed_rngs[w] = np.random.default_rng(given)
            episode_seeds[w] = int(self._seed_rngs[w].integers(SEED_BOUND)) if given is None else int(given)
        results = self.engine.reset(episode_seeds)
        for w, result in results.items():
            self._take(w, result)
        return results

    def step_results(self, actions: Sequence[dict[str, Any] | None]) -> dict[int, StepResult]:
        """Step every sub-environment that has agents (``actions[i]``: agent -> action; None: none given)."""
        if len(actions) != self.num_envs:
            raise ValueError(f"{len(actions)} action dicts for {self.num_envs} sub-environments")
        live = {w: dict(a or {}) for w, a in enumerate(actions) if self.agents[w]}
        results = self.engine.step(live)
        for w, result in results.items():
            self._take(w, result)
        return results

    def _take(self, w: int, result: StepResult) -> None:
        self.last_results[w] = result
        if result.discovered:  # rare (MCRE, PCALL, SCHEDULE): no set of every agent per step
            known = set(self.possible_agents[w])
            self.possible_agents[w] += [a for a in result.discovered if a not in known]
        self.agents[w] = list(result.alive)

    # ------------------------------------------------------- PettingZoo style
    def reset(self, seed: int | Sequence[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
        """``AamParallelEnv.reset`` of every sub-environment: lists of observation and info dicts.

        Sub-environments outside ``options["reset_mask"]`` give empty dicts.
        """
        results = self.reset_results(seed, options)
        obs: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for w, r in results.items():
            obs[w] = {a: r.obs.row(k) for k, a in enumerate(r.agents)}
            infos[w] = dict(zip(r.agents, r.infos()))
        return obs, infos

    def step(self, actions: Sequence[dict[str, Any] | None]) -> tuple[list[dict[str, Any]], ...]:
        """``AamParallelEnv.step`` of every sub-environment with agents: lists of dicts (empty for the others)."""
        results = self.step_results(actions)
        out: tuple[list[dict[str, Any]], ...] = tuple([{} for _ in range(self.num_envs)] for _ in range(5))
        for w, r in results.items():
            out[0][w] = {a: r.obs.row(k) for k, a in enumerate(r.agents)}
            out[1][w] = dict(zip(r.agents, r.rewards.tolist()))
            out[2][w] = dict(zip(r.agents, r.terminated.tolist()))
            out[3][w] = dict(zip(r.agents, r.truncated.tolist()))
            out[4][w] = dict(zip(r.agents, r.infos()))
        return out

    def metrics(self, env: int) -> dict[str, Any]:
        """The standard safety and operational metrics of sub-environment ``env``'s episode."""
        return self.engine.cores[env].metrics()

    def close(self) -> None:
        self.engine.close()
