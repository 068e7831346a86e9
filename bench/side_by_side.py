"""Run one benchmark script from two source trees, alternating, and print old vs new for every number it prints.

    python bench/side_by_side.py --before ../old-checkout --rounds 3 -- bench/bench_sim.py --sizes 100,1000 --no-day
    python bench/side_by_side.py --before ../old-checkout -- bench/bench_env.py --backends local --planners

The script (a path relative to each tree) runs as ``python SCRIPT ARGS`` with ``PYTHONPATH`` set
to the tree, ``--rounds`` times, old then new in even rounds and new then old in odd ones (ABBA: a
change in the machine's load hits both alike, and neither tree always runs first). Lines are matched by position; each number of a line is shown
as the median over the rounds, old -> new, with the change in percent. The machine's load
average is printed before and after: on a shared machine a few percent is within the noise.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NUMBER = re.compile(r"-?\d[\d,]*\.?\d*(?:[eE][-+]?\d+)?")


def run(tree: Path, script: str, args: list[str]) -> list[str]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("NUMBA_CACHE_DIR", None)  # each tree its own cache (aamsim.numba_cache keys it by the sources)
    proc = subprocess.run([sys.executable, str(tree / script), *args], capture_output=True, text=True, env=env,
                          cwd=tree, check=False)
    if proc.returncode:
        raise SystemExit(f"{tree / script} failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    return proc.stdout.splitlines()


def numbers(line: str) -> list[float]:
    return [float(m.replace(",", "")) for m in NUMBER.findall(line)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", type=Path, required=True, help="the old source tree")
    ap.add_argument("--after", type=Path, default=ROOT, help="the new source tree (default: this one)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("script", help="benchmark script, relative to each tree")
    ap.add_argument("args", nargs=argparse.REMAINDER)
    a = ap.parse_args(argv)
    args = a.args[1:] if a.args[:1] == ["--"] else a.args
    print(f"{a.script} {' '.join(args)}: old {a.before}, new {a.after}, {a.rounds} rounds alternating (ABBA); "
          f"load average {os.getloadavg()[0]:.1f}", flush=True)
    outputs: dict[str, list[list[str]]] = {"old": [], "new": []}
    trees = {"old": a.before.resolve(), "new": a.after.resolve()}
    for r in range(a.rounds):
        # ABBA: old first in even rounds, new first in odd ones, so that a load rising (or falling) over
        # the rounds does not favour the tree that always runs first.
        for which in ("old", "new") if r % 2 == 0 else ("new", "old"):
            outputs[which].append(run(trees[which], a.script, args))
    for k, line in enumerate(outputs["new"][0]):
        olds = [numbers(out[k]) if k < len(out) else [] for out in outputs["old"]]
        news = [numbers(out[k]) for out in outputs["new"]]
        width = min(len(x) for x in olds + news)
        if not width:
            print(f"  {line}")
            continue
        cells = []
        for c in range(width):
            old = statistics.median(x[c] for x in olds)
            new = statistics.median(x[c] for x in news)
            change = f" ({100 * (new / old - 1):+.1f} %)" if old and old != new else ""
            cells.append(f"{old:g} -> {new:g}{change}")
        label = NUMBER.split(line)[0].strip() or line[:30]
        print(f"  {label[:40]:40} " + "; ".join(cells))
    print(f"load average after: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
