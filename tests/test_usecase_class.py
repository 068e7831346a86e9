"""A use case given as a class (not registered) runs in-process; a server knows use cases by name only."""

from __future__ import annotations

from pathlib import Path

import pytest

import rlbridge
from rlbridge.usecases.reach import ReachDestination

TINY = str(Path(__file__).parent / "data" / "tiny_conflict.scn")


def test_a_class_runs_in_process_like_its_registered_name():
    by_class = rlbridge.parallel_env(TINY, usecase=ReachDestination, time_limit_s=120.0, arrival_bonus=2.0)
    by_name = rlbridge.parallel_env(TINY, usecase="reach_destination", time_limit_s=120.0, arrival_bonus=2.0)
    assert by_class.metadata["name"] == by_name.metadata["name"] == "aamgym_reach_destination_v1"
    obs_c, _ = by_class.reset(seed=3)
    obs_n, _ = by_name.reset(seed=3)
    assert list(obs_c) == list(obs_n) == ["TA1", "TB2"]
    for _ in range(5):
        step_c = by_class.step(dict.fromkeys(by_class.agents, 2))
        step_n = by_name.step(dict.fromkeys(by_name.agents, 2))
        assert step_c[1] == step_n[1]  # rewards
    assert by_class.core.usecase.params.arrival_bonus == 2.0


def test_a_class_is_refused_by_the_zmq_backend_with_the_reason():
    with pytest.raises(ValueError, match="registered name"):
        rlbridge.parallel_env(TINY, usecase=ReachDestination, backend="zmq", address="tcp://127.0.0.1:9")
