"""How fast a training run can go on the machine it runs on: its cores, its learner's device.

In ``train.mode=overlap`` the workers play iteration k+1 while the learner updates on iteration
k, so a run goes at the pace of the slower of the two:

* the rollouts: ``workers`` cores (one Ray worker each, ``workers=auto``: the cores the learner
  leaves, :func:`rlbridge.experiment.train.resolve_workers`), each playing about
  :data:`ROLLOUT_PER_CORE` aircraft-states per second;
* the learner: on a CPU, the whole-run rates measured on the 2-core development machine
  (``study.DEFAULT_RATES``, where the learner had one core): a lower bound for a machine with more
  cores, since the learners scale less than linearly with threads (issue 27 measured 16 cores at
  4-5 times 2 cores) and no larger CPU was measured; on CUDA not measured here (no GPU was
  available), so the estimate assumes the GPU learner keeps up and the rollouts bound the run.

``aamgym study --plan`` prints this estimate for the machine beside the one from the rates
measured on the 2-core development machine.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

# Aircraft-states per second one rollout worker plays on one core of the 2-core development
# machine (docs/algorithms.md, "Learning throughput": cProfile of one nyc_train_100 episode pair).
ROLLOUT_PER_CORE = {"d2mava": 8300.0, "dqn": 14700.0}

@dataclass(frozen=True)
class MachineEstimate:
    """Aircraft-states per second of each contender's run on one machine, and what bounds it."""

    cores: int
    device: str
    workers: int
    rates: dict[str, float]  # contender -> aircraft-states/s
    bound: dict[str, str]  # contender -> "rollouts" or "measured on 2 cores" (a CPU learner's run)


def machine_estimate(kinds: dict[str, str], device: str, workers: int, cpu_rates: dict[str, float],
                     cores: int | None = None) -> MachineEstimate:
    """The overlap-mode estimate (module docstring) for contenders ``kinds`` (name -> learner kind);
    ``cpu_rates``: aircraft-states/s of each contender's run with its learner on one CPU core."""
    cores = int(cores or os.cpu_count() or 1)
    rates, bound = {}, {}
    for name, kind in kinds.items():
        rollouts = ROLLOUT_PER_CORE[kind] * max(workers, 1)
        learner = float("inf") if device.startswith("cuda") else float(cpu_rates[name])
        rates[name] = min(rollouts, learner)
        bound[name] = "rollouts" if rollouts <= learner else "measured on 2 cores"
    return MachineEstimate(cores, device, workers, rates, bound)
