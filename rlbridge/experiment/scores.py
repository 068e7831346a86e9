"""``aamgym scores``: the reference-scores table of every registered use case.

    aamgym scores                                   # every use case, held-out traffic, fixed seeds
    aamgym scores --usecases corridor_sa --episodes 20 --out docs/results/scores
    aamgym scores --add runs/my_policy_export          # one more row, on the table's own seeds

For each use case (its Gymnasium id and version, its ``rlbridge/conf/usecase`` configuration): the
reference contender (unequipped aircraft, or no planning for a planner), every rule-based baseline
the use case names, and every shipped pretrained policy trained for it (``aamgym pretrained list``),
on the same fixed held-out seeds of the held-out scenario. Each figure is a mean with its 95 %
interval over those episodes (Student's t); every safety figure sits beside what it cost. The
table (``scores.md``, ``scores.csv``, and ``scores.json``: the same as data) says how it was made, and
``aamgym scores --add <exported policy folder>`` adds a researcher's row made the same way (the table's
scenario, seeds and episodes) without recomputing the others.
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import time
from pathlib import Path
from typing import Any

from aamsim.metrics.stats import mean_interval

log = logging.getLogger("aamgym.scores")

SEEDS_START = 2000  # fixed held-out evaluation seeds: SEEDS_START .. SEEDS_START + episodes - 1
# (figure key in summary.json, column title, digits): safety first, then what it cost.
COLUMNS = (
    ("reward_per_aircraft", "reward / flight", 3),  # per scheduled flight (episode_row)
    ("safety.nmac_events", "NMAC / episode", 2),
    ("safety.lowc_events", "LoWC / episode", 2),
    ("operational.flights_completed", "flights completed", 1),
    ("operational.flights_unfinished", "flights unfinished", 1),
    ("operational.flights_not_departed", "flights not departed", 1),
    ("operational.airborne_holding_s", "airborne holding [s]", 0),
    ("operational.mean_delay_s", "mean delay [s]", 1),
    ("operational.alert_rate_per_flight_hour", "advisories / flight hour", 1),
)


def usecase_contenders(usecase: str) -> tuple[str, list[str], list[str]]:
    """(reference baseline, other baselines, shipped pretrained policies) of a use case."""
    from rlbridge.policies import make_usecase_with_policies
    from rlbridge.pretrained import available, load

    own = list(make_usecase_with_policies(usecase).spec.baselines)
    reference = "no_planning" if "no_planning" in own else "unequipped"
    others = [b for b in own if b != reference]
    learned = [n for n in available() if load(n).usecase == usecase]
    return reference, others, learned


PLANNER_BLOCKS = ("strategic_planning", "hierarchical")  # summary blocks of use cases that hold departures back


IDENTICAL_MARK = " †"


def same_every_episode(figures: list[dict[str, float]]) -> bool:
    """Whether two or more episodes gave the very same figures (every seed played the same episode)."""
    return len(figures) > 1 and all(f == figures[0] for f in figures[1:])


def episode_row(summary: dict[str, Any], where: str) -> dict[str, float]:
    """One episode's figures for the table, every scheduled flight accounted for.

    Completed + unfinished + not departed must be the scheduled flights (a planner's requests): an
    episode where they are not is an error naming ``where`` (recompute it). An episode of a use case
    that holds no departure back, recorded before ``flights_not_departed`` existed, has none. The
    reward is per scheduled flight (a planner that keeps every flight on the ground created none).
    """
    op = dict(summary.get("operational") or {})
    requests = next((summary[b].get("requests") for b in PLANNER_BLOCKS if isinstance(summary.get(b), dict)), None)
    if "flights_not_departed" not in op and requests is None:
        op["flights_not_departed"] = 0
        op["flights_scheduled"] = op.get("flights")
    done, left, held = (op.get(k) for k in ("flights_completed", "flights_unfinished", "flights_not_departed"))
    scheduled = op.get("flights_scheduled")
    counted = sum((done, left, held)) if done is not None and left is not None and held is not None else None
    if counted is None or counted != scheduled or (requests is not None and counted > requests):
        raise ValueError(f"{where}: {done} completed + {left} unfinished + {held} not departed flights do not "
                         f"account for the {scheduled if requests is None else requests} "
                         f"{'scheduled flights' if requests is None else 'requests'} (an episode recorded before "
                         "flights_not_departed existed: delete its evaluation folder to recompute it)")
    row = {"reward_per_aircraft": summary.get("reward_total", 0.0) / max(scheduled or summary.get("flights_created", 1),
                                                                         1)}
    for group, values in (("safety", summary.get("safety") or {}), ("operational", op)):
        for k, v in values.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                row[f"{group}.{k}"] = float(v)
    return row


def _episode_figures(eval_dir: Path, policy: str) -> list[dict[str, float]]:
    return [episode_row(json.loads(f.read_text()), str(f))
            for f in sorted((eval_dir / "episodes" / policy).glob("seed-*/summary.json"))]


def _cell(values: list[float], digits: int) -> str:
    mi = mean_interval(values)
    if mi is None:
        return "n/a"
    if mi.half_width is None:
        return f"{mi.mean:.{digits}f}"
    return f"{mi.mean:.{digits}f} ± {mi.half_width:.{digits}f}"


TABLE_FILE = "scores.json"  # the table as data: its conditions and rows (scores.csv and scores.md are drawn from it)


def contender_row(usecase: str, eval_dir: Path, policy: str, suffix: str) -> dict[str, Any]:
    """One row of the table: a contender's figures over the episodes of one evaluation."""
    from rlbridge.usecases.registry import env_id

    ev = json.loads((eval_dir / "evaluation.json").read_text())
    figures = _episode_figures(eval_dir, policy)
    return {"environment": env_id(usecase), "contender": ev["policies"][policy]["label"] + suffix,
            "episodes": len(figures), "identical": same_every_episode(figures),
            "cells": [_cell([f[k] for f in figures if f.get(k) is not None], dg) for k, _, dg in COLUMNS]}


def run_scores(usecases: list[str], scenario: str, episodes: int, out: Path, work: Path, workers: int) -> Path:
    from rlbridge.experiment.evaluate import run_evaluation
    from rlbridge.experiment.study import _compose
    from rlbridge.pretrained import load

    rows: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    for uc in usecases:
        reference, others, learned = usecase_contenders(uc)
        common = _common(scenario, episodes, workers, uc)
        evals: list[tuple[Path, str, str]] = []  # (evaluation folder, its policy key, the row's name suffix)
        base_dir = work / uc / "baselines"
        if not (base_dir / "evaluation.json").exists():
            log.info("%s: %s against %s", uc, reference, ", ".join(others) or "nothing else")
            run_evaluation(_compose("evaluate", common + [f"baseline={reference}", f"baselines=[{','.join(others)}]"]),
                           base_dir, episode_cache=work / "cache")
        evals += [(base_dir, p, "") for p in [reference, *others]]
        for name in learned:
            d = work / uc / f"pretrained_{name}"
            if not (d / "evaluation.json").exists():
                log.info("%s: pretrained %s", uc, name)
                run_evaluation(_compose("evaluate", common + [f"policy=pretrained:{name}", "baselines=[]"]), d,
                               episode_cache=work / "cache")
            # The evaluation names a policy by its algorithm (its episodes folder too), the row by what ships.
            evals.append((d, load(name).name, f" (pretrained `{name}`)"))
        rows += [contender_row(uc, d, policy, suffix) for d, policy, suffix in evals]
    table = {"scenario": scenario, "episodes": episodes, "seed_start": SEEDS_START, "usecases": list(usecases),
             "date": time.strftime("%Y-%m-%d"), "wall_min": round((time.perf_counter() - t0) / 60, 1),
             "rows": rows, "added": []}
    return write_scores(out, table)


def _common(scenario: str, episodes: int, workers: int, usecase: str, seed: int = SEEDS_START) -> list[str]:
    return [f"scenario={scenario}", f"episodes={episodes}", f"seed={seed}", f"workers={workers}",
            f"usecase={usecase}"]


def add_score(policy: str, out: Path, work: Path, workers: int) -> Path:
    """``aamgym scores --add POLICY``: one more row (a shipped or exported policy) in the table in ``out``,
    made exactly as its rows were (the same scenario, seeds and episodes, read from ``scores.json``); a row
    of the same contender is replaced. The other rows are kept as they are, not recomputed."""
    from rlbridge.experiment.evaluate import run_evaluation
    from rlbridge.experiment.study import _compose
    from rlbridge.pretrained import PREFIX, SHIPPED_DIR, load

    path = out / TABLE_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no scores table to add a row to; make one first (aamgym scores --out {out})")
    table = json.loads(path.read_text())
    loaded = load(policy)
    shipped = loaded.folder.parent == SHIPPED_DIR
    name = loaded.folder.name
    # The row names what ships by its name; an exported folder by its own name (not the machine's path).
    suffix = f" (pretrained `{name}`)" if shipped else f" (`{name}`)"
    shown = f"{PREFIX}{name}" if shipped else f"<exported policy folder {name}>"
    uc = loaded.usecase
    d = work / uc / (f"pretrained_{name}" if shipped else f"exported_{name}")
    t0 = time.perf_counter()
    if (d / "evaluation.json").exists():
        import shutil

        shutil.rmtree(d)  # a folder of this name may hold an older policy (the cache knows its weights)
    log.info("%s: %s on %s, %d episodes from seed %d", uc, shown, table["scenario"], table["episodes"],
             table["seed_start"])
    common = _common(str(table["scenario"]), int(table["episodes"]), workers, uc, int(table["seed_start"]))
    run_evaluation(_compose("evaluate", common + [f"policy={loaded.folder if not shipped else PREFIX + name}",
                                                  "baselines=[]"]), d, episode_cache=work / "cache")
    row = contender_row(uc, d, loaded.name, suffix)
    rows: list[dict[str, Any]] = table["rows"]
    same = [k for k, r in enumerate(rows) if (r["environment"], r["contender"]) == (row["environment"],
                                                                                     row["contender"])]
    if same:
        rows[same[0]] = row
    else:  # after the last row of its environment (at the end when the table has none)
        last = max((k for k, r in enumerate(rows) if r["environment"] == row["environment"]), default=len(rows) - 1)
        rows.insert(last + 1, row)
    table["added"] = [a for a in table.get("added", []) if a["contender"] != row["contender"]] + [
        {"contender": row["contender"], "environment": row["environment"], "command": f"aamgym scores --add {shown}",
         "date": time.strftime("%Y-%m-%d"), "wall_min": round((time.perf_counter() - t0) / 60, 1)}]
    return write_scores(out, table)


def write_scores(out: Path, table: dict[str, Any]) -> Path:
    """``scores.json`` (the table as data), ``scores.csv`` and ``scores.md`` (drawn from it)."""
    out.mkdir(parents=True, exist_ok=True)
    (out / TABLE_FILE).write_text(json.dumps(table, indent=1, ensure_ascii=False) + "\n")
    rows = table["rows"]
    header = ["environment", "contender", "episodes", *[t for _, t, _ in COLUMNS]]
    with open(out / "scores.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows([r["environment"], r["contender"], str(r["episodes"]), *r["cells"]] for r in rows)
    stem = Path(str(table["scenario"])).stem
    episodes, seed0 = int(table["episodes"]), int(table["seed_start"])
    command = f"aamgym scores --usecases {' '.join(table['usecases'])} --scenario {stem} --episodes {episodes}"
    intro = (f"Held-out traffic `{stem}`, seeds {seed0} .. {seed0 + episodes - 1} (the same for every "
             "contender), each use case with its configuration in `rlbridge/conf/usecase` and the episode variation "
             "of its `-v1` environment (docs/usecases.md, \"Episode variation\"). Each cell: mean ± half-width of "
             "the 95 % interval over the episodes (Student's t). Safety figures sit beside what they cost. Every "
             "scheduled flight is counted: completed (arrived), unfinished (took off, not arrived: still flying at "
             "the end of the episode, or deleted elsewhere) or not departed (kept on the ground to the end by a "
             "departure planner: rejected, or released after the end); the three add up to the flights "
             "scheduled to depart before the end. Unfinished and not departed flights count in the mean delay, "
             "to the end of the episode (a lower bound of what they would have been), and unfinished ones in the "
             "airborne holding. The delay is against the scheduled arrival (the RTA, at the filed cruise speed): "
             "negative when flights fly faster than filed. The reward is per scheduled flight. A change of an environment's behaviour bumps "
             "its version; compare rows of the same version only.")
    made = (f"Made by `{command}` ({table['date']}); add your policy's row, played on the same seeds, with "
            "`aamgym scores --add <exported policy folder>` (or `--add pretrained:<name>`).")
    lines = ["# Reference scores", "", intro, "", made, "",
             "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join([r["environment"], r["contender"],
                                 str(r["episodes"]) + (IDENTICAL_MARK if r["identical"] else ""), *r["cells"]]) + " |"
              for r in rows]
    if any(r["identical"] for r in rows):
        lines += ["", (f"{IDENTICAL_MARK.strip()} Every episode of this row gave the same figures: nothing the "
                       "seed draws changed what it did (docs/usecases.md, \"Episode variation\"), so its interval "
                       "does not say how its figures vary with the traffic.")]
    note = (f"Wall time of this table's evaluations on the machine that made it: {table['wall_min']:.1f} min "
            "(cached episodes not counted).")
    lines += ["", note]
    for a in table.get("added", []):
        lines += ["", (f"Row added later: {a['contender']} ({a['environment']}), by `{a['command']}` "
                       f"({a['date']}, {a['wall_min']:.1f} min).")]
    (out / "scores.md").write_text("\n".join(lines) + "\n")
    return out / "scores.md"


def main(argv: list[str] | None = None) -> None:
    from rlbridge.usecases.registry import available

    ap = argparse.ArgumentParser(prog="aamgym scores", description=__doc__.split("\n\n")[0])
    ap.add_argument("--usecases", nargs="+", default=None, help="default: every registered use case")
    ap.add_argument("--scenario", default="nyc_eval_678", help="held-out traffic (default nyc_eval_678)")
    ap.add_argument("--episodes", type=int, default=10, help="seeds per contender (default 10)")
    ap.add_argument("--workers", type=int, default=0, help="Ray workers (0: in process)")
    ap.add_argument("--work", type=Path, default=Path("runs/scores"), help="evaluation runs (default runs/scores)")
    ap.add_argument("--out", type=Path, default=Path("docs/results/scores"))
    ap.add_argument("--add", metavar="POLICY", default=None,
                    help="add one row to the table in --out: a shipped policy (pretrained:<name>) or an exported "
                         "policy folder, played on the table's own scenario, seeds and episodes; the other rows "
                         "stay as they are")
    args = ap.parse_args(argv)
    if args.add is not None:
        if args.usecases or args.scenario != ap.get_default("scenario") or args.episodes != ap.get_default("episodes"):
            ap.error("--add plays the policy on the table's own scenario, seeds and episodes (its scores.json) in "
                     "its own use case: give no --usecases, --scenario or --episodes with it")
        logging.basicConfig(level=logging.INFO, format="[%(asctime)s][%(name)s][%(levelname)s] - %(message)s")
        try:
            print(add_score(args.add, args.out, args.work, args.workers))
        except FileNotFoundError as err:
            ap.exit(2, f"aamgym scores: error: {err}\n")
        return
    known = available()
    usecases: list[Any] = args.usecases or known
    unknown = [u for u in usecases if u not in known]
    if unknown:
        ap.error(f"unknown use case(s) {', '.join(unknown)}; registered: {', '.join(known)}")
    if args.episodes < 2:
        ap.error("--episodes must be at least 2 (an interval needs two episodes)")
    logging.basicConfig(level=logging.INFO, format="[%(asctime)s][%(name)s][%(levelname)s] - %(message)s")
    print(run_scores(usecases, args.scenario, args.episodes, args.out, args.work, args.workers))
