"""Frozen policies reach the use cases injected (rlbridge.usecases.frozen.PolicySource), not imported."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from aamsim.snapshots import TrafficSnapshot
from rlbridge.usecases.frozen import FrozenPolicy

CROSS = str(Path(__file__).parent / "data" / "strategic_cross.scn")
NO_LAYERS = {"layers_ft": [], "max_delay_slots": 2}


@dataclass
class _Out:
    actions: np.ndarray | None
    advise: np.ndarray | None = None


class _HoldEveryone:
    """An actor of our own: the corridor's "hold" (1) for every aircraft; notes the snapshots it was given."""

    obs_format = None
    snapshot_fields = ("cas",)

    def __init__(self) -> None:
        self.seen: list[TrafficSnapshot] = []

    def act(self, result, snapshot, rng, explore):
        self.seen.append(snapshot)
        return _Out(np.ones(len(result.agents), np.int64))


class _Source:
    """A policy source of our own (what rlbridge.policies.RegistryPolicies is for the registry)."""

    def __init__(self) -> None:
        self.asked: list[tuple] = []
        self.actor = _HoldEveryone()

    def baselines(self) -> tuple[str, ...]:
        return ("unequipped", "slow", "fcfs")

    def __call__(self, ref, role, allowed=None):
        self.asked.append((ref, role, allowed))
        return FrozenPolicy(ref, self.actor, {}, None, {}, None)


def test_a_tactical_layer_flies_the_injected_policy_on_snapshots():
    from rlbridge.core import EpisodeCore
    from rlbridge.usecases.strategic import StrategicPlanning

    source = _Source()
    core = EpisodeCore(CROSS, StrategicPlanning(source, tactical="slow", **NO_LAYERS), time_limit_s=900.0)
    assert source.asked == [("slow", "tactical layer", ("unequipped", "slow"))]  # planners are not tactical
    result = core.reset(1)
    while not result.done:
        result = core.step({"planner": 0})
    seen = source.actor.seen
    assert seen and all(isinstance(s, TrafficSnapshot) and s.fields == ("cas",) for s in seen)
    assert core.metrics()["strategic_planning"]["tactical_decisions"] == sum(len(s.ids) for s in seen) > 0


def test_a_use_case_built_without_a_source_flies_no_policy_and_names_how_to_get_one():
    from rlbridge.usecases.registry import make_usecase

    assert not make_usecase("strategic_planning").tactical.active  # unequipped: needs no source
    with pytest.raises(ValueError, match="tactical layer 'mvp_speed': a frozen policy other than 'unequipped' needs "
                                         "a policy source; build the use case with "
                                         "rlbridge.policies.make_usecase_with_policies"):
        make_usecase("strategic_planning", tactical="mvp_speed")
    from rlbridge.policies import make_usecase_with_policies

    assert make_usecase_with_policies("strategic_planning", tactical="mvp_speed").tactical.active
