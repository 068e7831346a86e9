"""Pretrained policies shipped with the package: weights as plain data, their spec and provenance.

    from rlbridge.pretrained import available, load
    policy = load("d2mava_a")                       # or a folder holding policy.json + policy.npz
    env = rlbridge.parallel_env("nyc_eval_678", usecase=policy.usecase, **policy.env_params)
    obs, _ = env.reset(seed=1)
    obs, rewards, terms, truncs, infos = env.step(policy.actions(obs))

    aamgym evaluate policy=pretrained:d2mava_a scenario=nyc_eval_678 episodes=100
    aamgym pretrained list                          # what ships, with provenance
    aamgym pretrained ship EXPORT_DIR NAME          # a study's exported run becomes a shipped policy
    aamgym pretrained actions d2mava_a --scenario nyc_train_100 --seed 5   # which actions it chooses

Each shipped policy is a folder ``rlbridge/pretrained/<name>/`` with ``policy.json`` (actor spec,
use case and its parameters, provenance: the code that trained it, seed, budget, best iteration),
``policy.npz`` (the network's weights, loaded with ``allow_pickle=False``) and ``reference.json``
(its evaluation figures on a few seeds, which ``tests/test_pretrained.py`` reproduces).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from rlbridge.experiment.export import ExportedPolicy, load_policy

SHIPPED_DIR = Path(__file__).resolve().parent
PREFIX = "pretrained:"


def available() -> list[str]:
    """Names of the policies shipped with the package."""
    return sorted(p.name for p in SHIPPED_DIR.iterdir() if (p / "policy.json").is_file())


def policy_dir(name_or_path: str | Path) -> Path:
    """The folder of a shipped policy (``d2mava_a`` or ``pretrained:d2mava_a``), or a folder given as a path."""
    text = str(name_or_path)
    name = text.removeprefix(PREFIX)
    shipped = SHIPPED_DIR / name
    if "/" not in name and (shipped / "policy.json").is_file():
        return shipped
    folder = Path(name)
    if (folder / "policy.json").is_file():
        return folder
    known = ", ".join(available()) or "none shipped yet"
    raise FileNotFoundError(f"no pretrained policy {text!r}: give a shipped name ({known}) or a folder holding "
                            "policy.json and policy.npz")


class PretrainedPolicy:
    """A shipped (or exported) policy that acts on a PettingZoo environment's observations, greedily."""

    def __init__(self, exported: ExportedPolicy, folder: Path):
        from rlbridge.agents import make_actor

        self.exported = exported
        self.folder = folder
        self.actor = make_actor(exported.actor_spec)
        self.actor.set_weights(exported.weights)

    @property
    def name(self) -> str:
        return self.exported.name

    @property
    def usecase(self) -> str:
        return self.exported.usecase

    @property
    def env_params(self) -> dict[str, Any]:
        """The use-case parameters it was trained with, with the observation format its network reads."""
        return {**self.exported.usecase_params, "obs_format": self.actor.obs_format}

    @property
    def provenance(self) -> dict[str, Any]:
        return self.exported.provenance

    def actions(self, observations: dict[str, Any]) -> dict[str, int]:
        """The greedy action of every agent in a PettingZoo observation dict (obs_format of :attr:`env_params`)."""
        import torch

        agents = list(observations)
        if not agents:
            return {}
        first = observations[agents[0]]
        with torch.no_grad():
            if isinstance(first, dict):  # D2MAV-A: ownship, padded intruders and their mask
                parts = {k: torch.from_numpy(np.stack([observations[a][k] for a in agents]).astype(np.float32))
                         for k in ("ownship", "intruders", "mask")}
                scores = self.actor.model(parts["ownship"], parts["intruders"], parts["mask"])[0]
            else:  # a flat observation: the Q-network
                flat = torch.from_numpy(np.stack([observations[a] for a in agents]).astype(np.float32))
                scores = self.actor.q(flat)
        return dict(zip(agents, (int(x) for x in scores.argmax(dim=1).tolist())))


def action_counts(policy: PretrainedPolicy, scenario: str, seed: int,
                  time_limit_s: float | None = None) -> dict[int, int]:
    """How often the policy chose each of its actions in one episode, played greedily in process.

    Every action of the environment's action space is a key (0 when never chosen); the values add up
    to the episode's agent-decisions. What a ratio table cannot show: whether a policy reacts to the
    traffic at all (a corridor policy that accelerates in every decision flies at its top speed).
    """
    import rlbridge
    from aamsim.scenarios import resolve_scenario

    path = resolve_scenario(scenario) or Path(scenario)
    kwargs: dict[str, Any] = {"time_limit_s": time_limit_s} if time_limit_s else {}
    env = rlbridge.parallel_env(str(path), usecase=policy.usecase, **policy.env_params, **kwargs)
    try:
        obs, _ = env.reset(seed=seed)
        space = env.action_space(env.possible_agents[0])
        if not isinstance(space, gym.spaces.Discrete):
            raise TypeError(f"action_counts counts discrete actions; {policy.usecase} acts in {space}")
        n_actions = int(space.n)
        counts = dict.fromkeys(range(n_actions), 0)
        while env.agents:
            actions = policy.actions(obs)
            for a in actions.values():
                counts[a] += 1
            obs, *_ = env.step(actions)
    finally:
        env.close()
    return counts


def load(name_or_path: str | Path) -> PretrainedPolicy:
    """A shipped policy by name (see :func:`available`), or an exported policy folder."""
    folder = policy_dir(name_or_path)
    return PretrainedPolicy(load_policy(folder), folder)


def reference(name_or_path: str | Path) -> dict[str, Any]:
    """The evaluation figures recorded when the policy was shipped (``reference.json``)."""
    return dict(json.loads((policy_dir(name_or_path) / "reference.json").read_text()))
