"""A tactical layer inside a simulation: speed advisories to every aircraft by a frozen policy.

The planner use cases fly their flights "unequipped, or with a tactical
layer": every ``interval_s`` the layer observes every aircraft as the
corridor use case does (``corridor_sa``: its observation, speed advisories
and advisory records) and applies the actions of a frozen policy
(:mod:`rlbridge.usecases.frozen`, built by the injected policy source):
``unequipped`` (none), a speed-advisory baseline (``mvp_speed``, ``daa``) or a
trained corridor policy (a training run directory or checkpoint).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from rlbridge.usecases.frozen import NO_POLICY, FrozenPolicy, PolicySource, SimHandle, frozen_policy

if TYPE_CHECKING:
    from aamsim import Simulation

# Baselines that are not speed advisories to aircraft: they plan departures, or turn and change level.
PLANNER_BASELINES = ("no_planning", "fcfs")
MANOEUVRE_BASELINES = ("mvp",)


def tactical_baselines(policies: PolicySource | None) -> tuple[str, ...]:
    """The baselines that give aircraft speed advisories (a tactical layer, the corridor use cases)."""
    known = policies.baselines() if policies is not None else (NO_POLICY,)
    return tuple(b for b in known if b not in PLANNER_BASELINES + MANOEUVRE_BASELINES)


class TacticalLayer:
    """Speed advisories every ``interval_s`` from a frozen policy (module docstring)."""

    def __init__(self, ref: str, interval_s: float = 10.0, corridor_params: dict[str, Any] | None = None,
                 policies: PolicySource | None = None):
        if not interval_s > 0:
            raise ValueError("tactical_interval_s must be positive")
        self.ref = ref
        self.interval_s = interval_s
        self.policy: FrozenPolicy = frozen_policy(ref, "tactical layer", tactical_baselines(policies), policies)
        if self.policy.usecase not in (None, "corridor_sa"):
            raise ValueError(f"tactical layer {ref!r} was trained on {self.policy.usecase}, not corridor_sa")
        params = {k: v for k, v in (corridor_params or self.policy.usecase_params).items()
                  if not k.startswith("alt_noise")}  # the episode's own noise applies, not the training's
        if self.policy.obs_format is not None:
            params["obs_format"] = self.policy.obs_format
        from rlbridge.usecases.corridor import CorridorSA

        self.corridor = CorridorSA(**params)
        self._rng = np.random.default_rng(0)
        self._handle: SimHandle | None = None
        self.decisions = 0  # aircraft-decisions taken in this episode

    @property
    def active(self) -> bool:
        return self.ref != NO_POLICY

    def attach(self, sim: Simulation, seed: int | None) -> None:
        """Act on ``sim`` every interval from now on (a new episode)."""
        self._rng = np.random.default_rng(np.random.SeedSequence([0 if seed is None else int(seed), 0x7AC]))
        self._handle = SimHandle(sim, seed, self.corridor)  # the corridor's speed actions
        self.decisions = 0
        if self.active:
            sim.hooks.pre_step.add(self.act, interval_s=self.interval_s, name="tactical.layer", priority=50)

    def act(self, sim: Simulation) -> None:
        agents = list(sim.view.ids)
        if not agents or self._handle is None:
            return
        obs = self.corridor.observe(sim, agents)
        actions = self.policy.act(self._handle, agents, obs, self._rng)
        self.decisions += len(agents)
        if actions is None:
            return
        self.corridor.apply_actions(sim, {a: int(x) for a, x in zip(agents, actions) if x >= 0})
