"""How fast a training run can go on the machine it runs on: its cores, its learner's device.

In ``train.mode=overlap`` the workers play iteration k+1 while the learner updates on iteration
k, so a run goes at the pace of the slower of the two:

* the rollouts: ``workers`` cores (one Ray worker each, ``workers=auto``: the cores the learner
  leaves, :func:`rlbridge.experiment.train.resolve_workers`), each playing about
  :data:`ROLLOUT_PER_CORE` aircraft-states per second;
* the learner: on a CPU, the whole-run rates measured on the 2-core development machine
  (``study.DEFAULT_RATES``, where the learner had one core): a lower bound for a machine with more
  cores, since the learners scale less than linearly with threads (issue 27 measured 16 cores at
  4-5 times 2 cores) and no larger CPU was measured; on CUDA the learner alone as
  ``bench/bench_learner.py`` measured it on an NVIDIA H200 (:data:`CUDA_LEARNER_RATES`; a
  contender not measured there is assumed to keep up with its rollouts, and the bound says so).

``aamgym study --plan`` prints this estimate for the machine beside the one from the rates
measured on the 2-core development machine.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

# Aircraft-states per second one rollout worker plays on one core of the 2-core development
# machine (docs/algorithms.md, "Learning throughput": cProfile of one nyc_train_100 episode pair).
ROLLOUT_PER_CORE = {"d2mava": 8300.0, "dqn": 14700.0}

# Aircraft-states per second of the learner alone on CUDA (the static path, CUDA graphs), per
# contender: ``python bench/bench_learner.py --devices cpu cuda --threads 16`` on one NVIDIA H200,
# 2026-11-27 (docs/algorithms.md, "The learner alone"; docs/results/bench/bench_learner_h200.json).
CUDA_LEARNER_RATES = {"d2mava_a": 73794.0, "d2mava_a_shared": 107100.0, "ddqn": 989238.0,
                      "ddqn_per_transition": 15182.0}

@dataclass(frozen=True)
class MachineEstimate:
    """Aircraft-states per second of each contender's run on one machine, and what bounds it."""

    cores: int
    device: str
    workers: int
    rates: dict[str, float]  # contender -> aircraft-states/s
    bound: dict[str, str]  # contender -> what bounds it: "rollouts", or the learner's measurement


def machine_estimate(kinds: dict[str, str], device: str, workers: int, cpu_rates: dict[str, float],
                     cores: int | None = None) -> MachineEstimate:
    """The overlap-mode estimate (module docstring) for contenders ``kinds`` (name -> learner kind);
    ``cpu_rates``: aircraft-states/s of each contender's run with its learner on one CPU core."""
    cores = int(cores or os.cpu_count() or 1)
    rates, bound = {}, {}
    for name, kind in kinds.items():
        rollouts = ROLLOUT_PER_CORE[kind] * max(workers, 1)
        if device.startswith("cuda"):
            learner = CUDA_LEARNER_RATES.get(name, float("inf"))
            learner_bound = "learner, measured alone on an H200"
        else:
            learner, learner_bound = float(cpu_rates[name]), "measured on 2 cores"
        rates[name] = min(rollouts, learner)
        if rollouts <= learner:
            bound[name] = "rollouts" if learner < float("inf") or not device.startswith("cuda") else \
                "rollouts (GPU learner not measured: assumed to keep up)"
        else:
            bound[name] = learner_bound
    return MachineEstimate(cores, device, workers, rates, bound)
