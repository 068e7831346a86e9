"""Use-case registry: a use case defines spaces, observations, rewards and action effects.

A new use case is a new module that defines a class following
:class:`UseCase` and declares an entry point in the ``rlbridge.usecases``
group (or is passed to an environment as an instance); the environments and
the server look use cases up by name and need no edit.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import import_module
from importlib.metadata import entry_points
from typing import TYPE_CHECKING, Any, Protocol

import gymnasium as gym
import numpy as np

if TYPE_CHECKING:
    from aamsim import Simulation


@dataclass
class Observations:
    """Observations of several agents as arrays (row k belongs to agent k)."""

    flat: np.ndarray | None = None  # (n, dim) when the use case emits flat vectors
    parts: dict[str, np.ndarray] | None = None  # name -> (n, ...) when it emits a Dict space

    def row(self, k: int) -> Any:
        if self.parts is not None:
            return {name: arr[k] for name, arr in self.parts.items()}
        assert self.flat is not None
        return self.flat[k]

    def __len__(self) -> int:
        if self.parts is not None:
            return len(next(iter(self.parts.values())))
        return 0 if self.flat is None else len(self.flat)


class UseCase(Protocol):
    """What a use case provides (all methods pure functions of the simulation state)."""

    name: str

    def observation_space(self) -> gym.Space: ...

    def action_space(self) -> gym.Space: ...

    def attach(self, sim: Simulation) -> None:
        """Prepare a fresh simulation (hooks, settings) before the scenario loads."""

    def observe(self, sim: Simulation, agents: list[str]) -> Observations: ...

    def closest_distances(self, sim: Simulation, agents: list[str]) -> np.ndarray:
        """Per agent, the distance to its closest intruder [m] (inf when none is in range)."""

    def rewards(self, sim: Simulation, agents: list[str], actions: dict[str, Any],
                closest_m: np.ndarray, interval_nmac_min_m: dict[str, float]) -> np.ndarray:
        """Per agent reward, given its closest-intruder distance now and the smallest NMAC
        distance it reached during the interval (agents with no NMAC event are absent)."""

    def apply_actions(self, sim: Simulation, actions: dict[str, Any]) -> None: ...


BUILTIN_USECASES: dict[str, str] = {"corridor_sa": "rlbridge.usecases.corridor:CorridorSA"}


def available() -> list[str]:
    names = set(BUILTIN_USECASES) | {ep.name for ep in entry_points(group="rlbridge.usecases")}
    return sorted(names)


def make_usecase(name: str, **params: Any) -> UseCase:
    """Instantiate a use case by name with parameters (unknown parameters are an error)."""
    target = BUILTIN_USECASES.get(name)
    if target is None:
        for ep in entry_points(group="rlbridge.usecases"):
            if ep.name == name:
                return ep.load()(**params)
        raise KeyError(f"unknown use case {name!r}; available: {', '.join(available())}")
    module, _, attr = target.partition(":")
    return getattr(import_module(module), attr)(**params)
