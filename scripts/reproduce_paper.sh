#!/usr/bin/env bash
# The paper's whole study (docs/algorithms.md, "Reproducing the paper's study"):
# D2MAV-A No Shared Layers, D2MAV-A Shared Layers and DDQN with the paper's hyper-parameters,
# 15 M aircraft-states each, 2 seeds, the paper's use case and the corrected variant v1,
# evaluated for 100 seeds on nyc_train_100 and nyc_eval_678, greedy and sampled, against the
# unequipped aircraft and the MVP baseline; tables, curves and configurations in docs/results/study.
#
#   scripts/reproduce_paper.sh --plan                 # what runs, and the time estimate
#   scripts/reproduce_paper.sh --smoke                # the whole pipeline, tiny (about 30 min on 2 cores)
#   scripts/reproduce_paper.sh                        # the study (resumes where it stopped)
#   scripts/reproduce_paper.sh --workers 8 --baselines mvp_speed daa device=cuda
set -euo pipefail
cd "$(dirname "$0")/.."
exec python -m rlbridge.experiment study "$@"
