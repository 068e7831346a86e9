"""Whole ``aamsim run`` of a scenario, this tree against another one, alternating: the cost of
the periodic provisional ``summary.json`` (issue 26 item 10) and of the open-ended-run checks.

    python bench/bench_run_summary.py --before OLD_TREE                 # scn/nyc_day.scn, 3 runs each
    python bench/bench_run_summary.py --before OLD_TREE --repeat 5 --scenario scn/nyc_train_100.scn

``OLD_TREE`` is another aamsim source tree (e.g. ``git archive <commit> | tar -x -C OLD_TREE``).
Each tree first makes one untimed run (Numba's cache, byte code), then the runs alternate, old
first. For every run: the wall time of the whole process, its CPU time (user + system, from the
child's resource usage: less sensitive than the wall to other work on a shared machine) and the
stepping time the run reports (``wall_time_s`` of its summary). Medians and new/old ratios follow.

    python bench/bench_run_summary.py --writes                  # the time spent in the writes themselves

``--writes`` runs the scenario once in this process (``aamsim run``'s code path) and times every
provisional write (the trajectory rows flushed, the summary made, written and renamed): their
number, total and largest time, and their share of the run's stepping time. On a machine too busy
for whole-run timings to resolve a small difference, this bounds the cost directly.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def one_run(tree: Path, scenario: str, out: Path, extra: list[str]) -> tuple[float, float, float]:
    """(process wall, process CPU, stepping wall reported) of ``aamsim run`` from ``tree`` [s]."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "aamsim", "run", scenario, "--quiet", "--out", str(out), *extra],
                   cwd=tree, env=env, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    stepping = float(json.loads((out / "summary.json").read_text())["wall_time_s"])
    return wall, cpu, stepping


def time_writes(scenario: str, extra: list[str]) -> None:
    """One in-process run with every provisional write timed (see the module docstring)."""
    from aamsim.output.summary_file import ProvisionalSummary
    from aamsim.runner import RunConfig, run_scenario

    spent: list[float] = []
    write = ProvisionalSummary.write

    def timed(self: ProvisionalSummary, wall_s: float) -> None:
        t0 = time.perf_counter()
        write(self, wall_s)
        spent.append(time.perf_counter() - t0)

    ProvisionalSummary.write = timed  # type: ignore[method-assign]
    until = float(extra[extra.index("--until") + 1]) if "--until" in extra else None
    with tempfile.TemporaryDirectory() as tmp:
        result = run_scenario(RunConfig(scenario, out_dir=Path(tmp) / "run", until_s=until))
    total = sum(spent)
    print(f"{scenario}: {len(spent)} provisional writes, {total * 1e3:.1f} ms in all (largest "
          f"{max(spent) * 1e3:.1f} ms), {100 * total / result.wall_s:.3f} % of the {result.wall_s:.1f} s of "
          f"stepping; load average {os.getloadavg()[0]:.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, metavar="DIR", help="the other (older) source tree")
    parser.add_argument("--writes", action="store_true", help="time the provisional writes of one run instead")
    parser.add_argument("--scenario", default="scn/nyc_day.scn")
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per tree")
    parser.add_argument("args", nargs="*", help="more arguments for aamsim run (after --)")
    a = parser.parse_args()
    if a.writes:
        time_writes(a.scenario, a.args)
        return
    if a.before is None:
        parser.error("--before DIR is needed (or --writes)")
    trees = {"old": a.before.resolve(), "new": ROOT}
    results: dict[str, list[tuple[float, float, float]]] = {"old": [], "new": []}
    with tempfile.TemporaryDirectory() as tmp:
        for name, tree in trees.items():
            one_run(tree, a.scenario, Path(tmp) / f"warm-{name}", a.args)
        print(f"{a.scenario} {' '.join(a.args)}; load average {os.getloadavg()[0]:.1f} at the start")
        print(f"{'run':>5} {'tree':>4} {'wall s':>8} {'cpu s':>8} {'stepping s':>10}")
        for k in range(a.repeat):
            for name, tree in trees.items():
                r = one_run(tree, a.scenario, Path(tmp) / f"{name}-{k}", a.args)
                results[name].append(r)
                print(f"{k + 1:>5} {name:>4} {r[0]:8.2f} {r[1]:8.2f} {r[2]:10.2f}", flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    for col, label in enumerate(("process wall", "process CPU", "stepping wall")):
        old = statistics.median(r[col] for r in results["old"])
        new = statistics.median(r[col] for r in results["new"])
        print(f"median {label:>13}: old {old:8.2f} s, new {new:8.2f} s, new/old {new / old:.3f}")


if __name__ == "__main__":
    main()
