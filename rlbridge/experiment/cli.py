"""``aamgym``: one command per step of the paper's study.

    aamgym train algorithm=d2mava_a scenario=nyc_train_100 workers=2 train.hours=1
    aamgym train --multirun algorithm=d2mava_a,d2mava_a_shared,ddqn seed=0,1,2
    aamgym evaluate run=runs/train/<run> scenario=nyc_eval_678 episodes=100
    aamgym report runs/eval/<run> runs/eval/<run> --train runs/train/<run> ... -o report/
    aamgym study [--smoke] [--plan]     # the paper's whole study: train, evaluate, report
    aamgym scores                       # the reference-scores table of every use case
    aamgym pretrained list              # the policies shipped with the package

``train`` and ``evaluate`` are Hydra applications (overrides, ``--multirun`` sweeps,
``--cfg job`` to print the configuration, ``--help``); ``report`` and ``study`` are plain commands.
"""

from __future__ import annotations

import sys

USAGE = """usage: aamgym {train,evaluate,report,study,scores,pretrained} [args...] | --version

  train     train an algorithm (Hydra overrides: algorithm=ddqn scenario=... workers=2 train.hours=1)
  evaluate  a training run's best weights (run=RUN_DIR) or a baseline (baseline=daa scenario=...) against the baselines
  report    tables and figures from evaluation and training runs (EVAL_DIR... --train TRAIN_DIR... -o OUT)
  study     the paper's whole study: every contender, seed and use-case variant, trained, evaluated, reported
  scores    the reference-scores table of every use case (baselines and shipped policies, held-out seeds)
  pretrained  the policies shipped with the package (list), or ship one from a study's exported run (ship)

'aamgym <command> --help' describes each command."""


# What each command imports (rl extra); evaluate and train check Ray, videos and BlueSky in preflight.
NEEDS = {"train": ("torch", "hydra", "omegaconf"), "evaluate": ("torch", "hydra", "omegaconf"),
         "study": ("torch", "hydra", "omegaconf"), "report": ("torch", "omegaconf"),
         "scores": ("torch", "hydra", "omegaconf"), "pretrained": ("torch",)}


def main(argv: list[str] | None = None) -> None:
    from aamsim.extras import EXTRAS, MissingExtra, missing, require

    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help", "help"):
        print(USAGE)
        absent = missing(EXTRAS["rl"][0])
        if absent:
            print(f'\nThese commands need the rl extra ({", ".join(absent)} not installed): pip install "aamsim[rl]"')
        sys.exit(0 if args else 2)
    if args[0] in ("-V", "--version"):
        from aamsim import __version__

        print(f"aamgym, version {__version__}")  # one version for the distribution, worded as aamsim --version
        sys.exit(0)
    command, rest = args[0], args[1:]
    if command not in NEEDS:
        print(f"aamgym: unknown command {command!r}\n\n{USAGE}", file=sys.stderr)
        sys.exit(2)
    try:
        require("rl", f"aamgym {command}", NEEDS[command])
    except MissingExtra as exc:
        print(f"aamgym {command}: error: {exc}", file=sys.stderr)
        sys.exit(2)
    if command == "report":
        from rlbridge.experiment.report import main as report_main

        report_main(rest)
        return
    if command == "study":
        from rlbridge.experiment.study import main as study_main

        study_main(rest)
        return
    if command == "scores":
        from rlbridge.experiment.scores import main as scores_main

        scores_main(rest)
        return
    if command == "pretrained":
        from rlbridge.pretrained.ship import main as pretrained_main

        pretrained_main(rest)
        return
    # Check every job's configuration before Hydra makes a run directory (and before Ray starts).
    from rlbridge.experiment.preflight import preflight

    problems = preflight("config" if command == "train" else "evaluate", rest)
    if problems:
        for line in problems:
            print(f"aamgym {command}: error: {line}", file=sys.stderr)
        sys.exit(2)
    # Hydra parses sys.argv itself: hand it the arguments after the sub-command.
    sys.argv = [f"aamgym {command}", *rest]
    if command == "train":
        from rlbridge.experiment.train import hydra_entry
    else:
        from rlbridge.experiment.evaluate import hydra_entry
    hydra_entry()


if __name__ == "__main__":
    main()
