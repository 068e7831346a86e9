"""``aamgym pretrained``: list the shipped policies, ship one from a study's exported run, count its actions.

    aamgym pretrained list
    aamgym pretrained ship docs/results/study/runs/corridor_sa/d2mava_a_s0 d2mava_a --scenario nyc_eval_678
    aamgym pretrained actions d2mava_a --scenario nyc_train_100 --seed 5

Shipping copies ``policy.json`` and ``policy.npz`` into ``rlbridge/pretrained/<name>/`` and records
``reference.json``: the greedy policy's figures on a few seeds of a scenario (NMAC and LoWC events,
the use case's reward, flights completed), played in process over the first ``--time-limit``
seconds of each episode (20 minutes by default: enough traffic to tell any change of the weights
or of the code's behaviour, and short enough to replay in every test run; the full episodes are
in the reference-scores table). ``tests/test_pretrained.py`` plays the
same seeds again and must find the same figures: a shipped file that no longer matches the code
that loads it fails the tests instead of publishing wrong numbers.
"""

from __future__ import annotations

import argparse
import json
import shutil
from dataclasses import replace
from pathlib import Path
from typing import Any

from rlbridge.pretrained import SHIPPED_DIR, action_counts, available, load, policy_dir

REFERENCE_SEEDS = (1000, 1001, 1002)  # held apart from training (episode seeds there are 31-bit hashes)
REFERENCE_TIME_LIMIT_S = 1200.0  # each reference episode's first 20 minutes of simulated time


def reference_figures(folder: str | Path, scenario: str, seeds: tuple[int, ...] = REFERENCE_SEEDS,
                      time_limit_s: float | None = REFERENCE_TIME_LIMIT_S) -> list[dict[str, Any]]:
    """The greedy policy's episode figures on ``seeds`` of ``scenario``, played in process.

    ``time_limit_s``: each episode ends there [s of sim time]; None: the episode as the policy was trained.
    """
    from rlbridge.agents.rollout import RolloutWorker
    from rlbridge.experiment.export import policy_env

    policy = load(folder)
    env = policy_env(policy.exported, scenario)
    if time_limit_s is not None:
        env = replace(env, time_limit_s=float(time_limit_s))
    worker = RolloutWorker(env, {"policy": policy.exported.actor_spec})
    worker.set_weights(policy.exported.weights, "policy")
    out = []
    for stats in worker.collect(list(seeds), "policy", None, policy.exported.greedy_explore, record=False):
        op = stats.metrics.get("operational", {})
        out.append({"seed": stats.seed, "nmac_events": stats.nmac_events, "lowc_events": stats.lowc_events,
                    "reward_total": stats.reward_total, "flights_completed": op.get("flights_completed"),
                    "aircraft": stats.aircraft})
    return out


def ship(export_dir: Path, name: str, scenario: str, seeds: tuple[int, ...] = REFERENCE_SEEDS,
         note: str = "", time_limit_s: float | None = REFERENCE_TIME_LIMIT_S) -> Path:
    """Copy an exported policy into the package and record its reference figures."""
    if not name.replace("_", "").isalnum():
        raise ValueError(f"policy name {name!r}: letters, digits and underscores only")
    dest = SHIPPED_DIR / name
    dest.mkdir(parents=True, exist_ok=True)
    for file in ("policy.json", "policy.npz"):
        shutil.copy(export_dir / file, dest / file)
    if note:
        spec = json.loads((dest / "policy.json").read_text())
        spec["provenance"]["note"] = note
        (dest / "policy.json").write_text(json.dumps(spec, indent=2) + "\n")
    figures = reference_figures(dest, scenario, seeds, time_limit_s)
    (dest / "reference.json").write_text(json.dumps({"scenario": Path(scenario).stem, "actions": "greedy",
                                                     "time_limit_s": time_limit_s, "episodes": figures},
                                                    indent=2) + "\n")
    return dest


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="aamgym pretrained", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="the shipped policies and their provenance")
    sp = sub.add_parser("ship", help="ship an exported policy (a folder with policy.json and policy.npz)")
    sp.add_argument("export_dir", type=Path)
    sp.add_argument("name")
    sp.add_argument("--scenario", default="nyc_eval_678", help="scenario of the reference figures")
    sp.add_argument("--seeds", type=int, nargs="+", default=list(REFERENCE_SEEDS))
    sp.add_argument("--note", default="", help="a line added to the provenance (e.g. what is interim about it)")
    sp.add_argument("--time-limit", type=float, default=REFERENCE_TIME_LIMIT_S,
                    help="seconds of simulated time of each reference episode (0: the whole episode)")
    ac = sub.add_parser("actions", help="how often a policy chooses each action in one episode (greedy)")
    ac.add_argument("policy", help="a shipped name or an exported policy folder")
    ac.add_argument("--scenario", default="nyc_train_100")
    ac.add_argument("--seed", type=int, default=REFERENCE_SEEDS[0])
    args = ap.parse_args(argv)
    if args.command == "actions":
        pol = load(args.policy)
        counts = action_counts(pol, args.scenario, args.seed)
        total = sum(counts.values())
        shares = ", ".join(f"action {a}: {n:,} ({100 * n / total if total else 0:.1f} %)" for a, n in counts.items())
        print(f"{args.policy} ({pol.exported.label}) on {Path(args.scenario).stem}, seed {args.seed}: {total:,} decisions; "
              f"{shares}")
        return
    if args.command == "list":
        names = available()
        if not names:
            print("no pretrained policy ships yet")
        for n in names:
            pol = load(n)
            prov = pol.provenance
            print(f"{n}: {pol.exported.label} on {pol.usecase}, seed {prov.get('seed')}, "
                  f"{prov.get('aircraft_states') or 0:,} aircraft-states (budget {prov.get('aircraft_states_budget')}),"
                  f" best iteration {prov.get('best_iteration')}; {policy_dir(n)}"
                  + (f"; {prov['note']}" if prov.get("note") else ""))
        return
    dest = ship(args.export_dir, args.name, args.scenario, tuple(args.seeds), args.note, args.time_limit or None)
    print(dest)
