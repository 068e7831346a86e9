"""RLlib adapter: the PettingZoo environment as an RLlib ``MultiAgentEnv`` (new API stack).

    from ray.rllib.algorithms.ppo import PPOConfig
    from rlbridge.rllib_env import AamMultiAgentEnv

    config = (PPOConfig()
              .environment(AamMultiAgentEnv, env_config={"scenario": "nyc_train_100", "obs_format": "flat"})
              .multi_agent(policies={"shared"}, policy_mapping_fn=lambda agent_id, episode, **kw: "shared"))
    algo = config.build_algo()
    algo.train()

(:func:`ppo_config` builds this configuration; ``examples/rllib_ppo.py`` runs it.)

``env_config`` holds :class:`~rlbridge.envs.AamParallelEnv`'s arguments (``scenario``,
``usecase``, ``backend``, ``address``, ``time_limit_s``, ``dt``) and the use-case parameters.
What RLlib 2.x's new API stack expects and this adapter provides:

* ``possible_agents`` (every callsign the scenario creates) and ``agents`` (the aircraft
  flying now), ``observation_spaces`` / ``action_spaces`` dicts over ``possible_agents``;
* an agent appears with its first observation (reward 0), acts while it flies, and leaves
  with ``terminateds[agent] = True`` and its final observation (arrival);
* ``terminateds["__all__"]`` / ``truncateds["__all__"]`` mark the end of the episode; at the
  time limit the remaining agents are truncated *with* an observation (RLlib needs it to
  bootstrap their values).

RLlib's default models take ``Box`` observations: use ``obs_format="flat"`` (the default).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym

from aamsim.extras import require

require("rl", "rlbridge.rllib_env (RLlib)", ("ray",))  # one line naming the extra instead of a bare ImportError

from ray.rllib.env.multi_agent_env import MultiAgentEnv

from rlbridge.envs import AamParallelEnv


class AamMultiAgentEnv(MultiAgentEnv):
    """The agents of a use case (``corridor_sa``: every airborne aircraft) as RLlib agents (module docstring)."""

    def __init__(self, config: dict[str, Any] | None = None):
        super().__init__()
        cfg = dict(config or {})
        scenario = cfg.pop("scenario", "nyc_train_100.scn")
        self.env = AamParallelEnv(scenario, **cfg)
        self.render_mode = self.env.render_mode
        self.possible_agents = list(self.env.possible_agents)
        self.agents = []
        if not self.possible_agents:
            raise ValueError(f"scenario {scenario} creates no aircraft")
        # Every agent of a use case shares its spaces; agents that join possible_agents later
        # (MCRE, PCALL, SCHEDULE) get them through get_observation_space / get_action_space.
        self._obs_space: gym.Space = self.env.observation_space(str(self.possible_agents[0]))
        self._act_space: gym.Space = self.env.action_space(str(self.possible_agents[0]))
        self._discrete = isinstance(self._act_space, gym.spaces.Discrete)
        self.observation_spaces = {a: self._obs_space for a in self.possible_agents}
        self.action_spaces = {a: self._act_space for a in self.possible_agents}

    def get_observation_space(self, agent_id: Any) -> gym.Space:
        return self._obs_space

    def get_action_space(self, agent_id: Any) -> gym.Space:
        return self._act_space

    def _sync_agents(self) -> None:
        self.agents = list(self.env.agents)
        for a in self.env.possible_agents[len(self.possible_agents):]:
            self.possible_agents.append(a)
            self.observation_spaces = {**(self.observation_spaces or {}), a: self._obs_space}
            self.action_spaces = {**(self.action_spaces or {}), a: self._act_space}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        obs, infos = self.env.reset(seed=seed, options=options)
        self._sync_agents()
        return obs, infos

    def step(self, action_dict: Any) -> Any:
        """Actions of the agents flying -> (obs, rewards, terminateds, truncateds, infos) with ``__all__``."""
        actions = {a: int(x) for a, x in action_dict.items()} if self._discrete else dict(action_dict)
        obs, rewards, terms, truncs, infos = self.env.step(actions)
        self._sync_agents()
        result = self.env.last_result
        done = bool(result is not None and result.done)
        truncated_all = done and any(truncs.values())
        terms["__all__"] = done and not truncated_all
        truncs["__all__"] = truncated_all
        return obs, rewards, terms, truncs, infos

    def render(self) -> Any:
        """``env_config["render_mode"]``: ``rgb_array`` returns an RGB image, ``human`` shows the web viewer."""
        return self.env.render()

    def metrics(self) -> dict[str, Any]:
        """The episode's standard safety and operational metrics."""
        return self.env.metrics()

    def close(self) -> None:
        self.env.close()


def ppo_config(scenario: str, env_runners: int = 0, batch: int = 256, minibatch: int = 64,
               time_limit_s: float | None = None, seed: int = 0, **usecase_params: Any) -> Any:
    """An RLlib ``PPOConfig`` on :class:`AamMultiAgentEnv` with one policy shared by every aircraft.

    Args:
        scenario: scenario name or path (made absolute so that remote env runners find it).
        env_runners: RLlib env-runner actors (0: sample in the driver).
        batch: ``train_batch_size_per_learner`` [agent steps]; ``minibatch``: SGD minibatch size.
        time_limit_s: episode limit [s of sim time] (None: last scenario command + 2 h).
        usecase_params: use-case parameters (``obs_format`` is forced to "flat").
    """
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    path = Path(scenario)
    env_config = {"scenario": str(path.resolve()) if path.exists() else scenario, "time_limit_s": time_limit_s,
                  **usecase_params, "obs_format": "flat"}
    return (
        PPOConfig()
        .environment(AamMultiAgentEnv, env_config=env_config)
        .multi_agent(policies={"shared"}, policy_mapping_fn=lambda agent_id, episode, **kw: "shared")
        .env_runners(num_env_runners=env_runners, rollout_fragment_length="auto")
        .training(train_batch_size_per_learner=batch, minibatch_size=minibatch, num_epochs=2, lr=3e-4)
        .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[128, 128]))
        .debugging(seed=seed)
    )
