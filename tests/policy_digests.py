"""Digests of whole episodes played by each policy kind (tests/test_policy_snapshots.py).

An episode's digest covers every decision (actions, advisory rows, observations,
rewards) and its metrics, so two runs with equal digests made the same decisions.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

DATA = Path(__file__).parent / "data"

# (name, scenario, use case, use-case parameters, actor spec, explore, seeds)
CASES: list[tuple[str, str, str, dict[str, Any], dict[str, Any], dict[str, Any], tuple[int, ...]]] = [
    ("unequipped", "three_way.scn", "corridor_sa", {}, {"kind": "unequipped"}, {}, (0, 1)),
    ("mvp_speed", "three_way.scn", "corridor_sa", {}, {"kind": "mvp_speed"}, {}, (0, 1)),
    ("mvp_speed_encounters", "daa_encounters.scn", "corridor_sa", {"alt_noise_ft": 0.0}, {"kind": "mvp_speed"}, {},
     (0,)),
    ("daa", "daa_encounters.scn", "corridor_sa", {"alt_noise_ft": 0.0}, {"kind": "daa"}, {}, (0,)),
    ("daa_reach", "tiny_conflict.scn", "reach_destination", {}, {"kind": "daa"}, {}, (0,)),
    ("mvp_turns", "daa_turns.scn", "heading_altitude_sa", {}, {"kind": "mvp"}, {}, (0,)),
    ("daa_turns", "daa_turns.scn", "heading_altitude_sa", {}, {"kind": "daa"}, {}, (0,)),
    ("fcfs", "strategic_cross.scn", "strategic_planning", {}, {"kind": "fcfs"}, {}, (0,)),
    ("fcfs_tactical_mvp", "strategic_cross.scn", "strategic_planning", {"tactical": "mvp_speed"}, {"kind": "fcfs"},
     {}, (0,)),
    ("hier_planner_fcfs", "strategic_cross.scn", "hierarchical", {"train": "tactical", "planner": "fcfs"},
     {"kind": "mvp_speed"}, {}, (0,)),
]


NETWORK_OUTPUTS = ("logp", "values")


def batch_digest(batch: Any, network_outputs: bool = True) -> str:
    """sha256 of an episode's decisions, observations, rewards and metrics (wall time left out).

    ``network_outputs=False`` leaves out the log-probabilities and values a learned actor's network
    computed: their last bits depend on the CPU's BLAS kernels and thread count (they differ between the
    Intel machine the digests were first recorded on and an AMD EPYC), so :func:`network_sums` checks
    them to a tolerance instead."""
    h = hashlib.sha256()
    names = ("obs_idx", "next_idx", "actions", "logp", "rewards", "terminated", "truncated", "agent", "values")
    for name in names if network_outputs else [n for n in names if n not in NETWORK_OUTPUTS]:
        h.update(name.encode())
        h.update(np.ascontiguousarray(getattr(batch, name)).tobytes())
    for key in sorted(batch.obs):
        h.update(key.encode())
        h.update(np.ascontiguousarray(batch.obs[key]).tobytes())
    stats = batch.stats.to_dict()
    stats.pop("wall_s")
    # The use case's declared metrics re-list figures of ``metrics`` (hashed below); the field came after
    # the digests were recorded.
    stats.pop("declared", None)
    h.update(json.dumps(stats, sort_keys=True, default=str).encode())
    return h.hexdigest()


def network_sums(batch: Any) -> tuple[float, ...]:
    """The sums of the network's outputs in an episode (log-probabilities, values), in float64."""
    return tuple(float(np.sum(np.asarray(getattr(batch, name), dtype=np.float64))) for name in NETWORK_OUTPUTS)


def learner_spec(kind: str, usecase: str, params: dict[str, Any]) -> tuple[dict[str, Any], Any]:
    """A learner's actor spec and weights as freshly initialised with seed 0 (deterministic)."""
    from rlbridge.agents import make_learner, usecase_dims

    learner = make_learner(kind, {}, usecase_dims(usecase, params), seed=0)
    return learner.actor_spec(kind), learner.weights()


def run_case(case: tuple[Any, ...]) -> list[str]:
    """Play the case's seeds one after another with a fresh worker; one digest per episode."""
    from rlbridge.agents.rollout import EnvSpec, RolloutWorker

    _, scenario, usecase, params, spec, explore, seeds = case
    worker = RolloutWorker(EnvSpec(str(DATA / scenario), usecase, params, time_limit_s=900.0),
                           {"policy": spec})
    return [batch_digest(b) for b in worker.collect(list(seeds), explore=explore)]


if __name__ == "__main__":  # print the digests (to record them in tests/test_policy_snapshots.py)
    out = {case[0]: run_case(case) for case in CASES}
    for kind, explore in (("dqn", {"epsilon": 0.3}), ("d2mava", {})):
        from rlbridge.agents.rollout import EnvSpec, RolloutWorker

        spec, weights = learner_spec(kind, "corridor_sa", {})
        worker = RolloutWorker(EnvSpec(str(DATA / "three_way.scn"), "corridor_sa", {}, time_limit_s=900.0),
                               {"policy": spec})
        out[kind] = [(batch_digest(b, network_outputs=False), *network_sums(b))
                     for b in worker.collect([0, 1], weights=weights, explore=explore)]
    print(json.dumps(out, indent=1))
