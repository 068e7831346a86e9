"""The heading / altitude action targets are computed only for an actor that reads them (issue 29).

The episode engine once added every action's target to every step result of a heading or
altitude use case, whatever the acting policy; a learner never reads them. Now an actor asks
(``reads_action_targets``: ``mvp``) and the engine publishes them only while it plays, in
process and over a real ZeroMQ server (the ``targets`` field of a reset).
"""

from __future__ import annotations

from typing import Any

import pytest
from bridge_util import thread_server

from rlbridge.usecases.protocol import UseCaseBase
from rlbridge.usecases.targets import TARGETS_KEY
from tests.policy_digests import DATA, learner_spec

SPEC = {"scenario": "daa_turns.scn", "usecase": "heading_altitude_sa", "params": {}, "time_limit_s": 900.0}


class Recording:
    """A real actor that also notes, per decision, whether its step result carried the action targets."""

    def __init__(self, actor: Any):
        self.actor = actor
        self.seen: list[bool] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self.actor, name)

    def act(self, result: Any, snapshot: Any, rng: Any, explore: dict[str, Any]) -> Any:
        self.seen.append(TARGETS_KEY in result.info)
        return self.actor.act(result, snapshot, rng, explore)


@pytest.fixture
def computed(monkeypatch) -> list[str]:
    """The kinds of every action-target computation of any use case of this process (server thread included)."""
    calls: list[str] = []
    original = UseCaseBase.action_targets

    def counting(self, sim, slots, kind):
        calls.append(kind)
        return original(self, sim, slots, kind)

    monkeypatch.setattr(UseCaseBase, "action_targets", counting)
    return calls


def _play(spec: dict[str, Any], actor_spec: dict[str, Any], weights: Any = None, **env: Any) -> Recording:
    from rlbridge.agents.rollout import EnvSpec, RolloutWorker

    worker = RolloutWorker(EnvSpec(**spec, **env), {"policy": actor_spec})
    rec = worker.actors["policy"] = Recording(worker.actors["policy"])
    worker.collect([0], weights=weights)
    worker.actors["policy"] = rec.actor
    return rec


@pytest.mark.parametrize("kind", ["dqn", "d2mava"])
def test_a_learners_rollout_on_a_heading_use_case_computes_no_action_targets(kind, computed):
    spec, weights = learner_spec(kind, "heading_altitude_sa", {})
    rec = _play({**SPEC, "scenario": str(DATA / SPEC["scenario"])}, spec, weights)
    assert rec.seen and not any(rec.seen)
    assert computed == []


def test_mvp_still_gets_the_action_targets_in_process_and_over_zeromq_and_a_learner_does_not(computed):
    here = _play({**SPEC, "scenario": str(DATA / SPEC["scenario"])}, {"kind": "mvp"})
    assert here.seen and all(here.seen)
    assert set(computed) == {"heading", "altitude"}
    spec, weights = learner_spec("dqn", "heading_altitude_sa", {})
    with thread_server(scenario_roots=(DATA,)) as server:
        computed.clear()
        there = _play(SPEC, {"kind": "mvp"}, backend="zmq", address=server.endpoint, timeout_s=600.0)
        assert there.seen == here.seen and set(computed) == {"heading", "altitude"}
        # The same server session's next episode, played by a learner: no targets computed or sent.
        computed.clear()
        learner = _play(SPEC, spec, weights, backend="zmq", address=server.endpoint, timeout_s=600.0)
        assert learner.seen and not any(learner.seen)
        assert computed == []
