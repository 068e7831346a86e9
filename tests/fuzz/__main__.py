"""``python -m tests.fuzz --lines 1000000 [--seed 0]``: the long fuzzing run, with progress and a summary."""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
import time
from pathlib import Path

from tests.fuzz.scenario import Harness, LineMaker


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--lines", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--budget", type=float, default=1.0, help="seconds a line may take")
    parser.add_argument("--report", type=Path, default=None, help="append failures here as JSON lines")
    args = parser.parse_args(argv)
    logging.disable(logging.CRITICAL)
    from tqdm import tqdm

    with tempfile.TemporaryDirectory() as folder:
        harness = Harness(Path(folder), budget_s=args.budget, log_path=args.report)
        if args.report is not None:
            args.report.write_text("")
        maker = LineMaker(args.seed)
        t0 = time.perf_counter()
        bar = tqdm(total=args.lines, unit="line", file=sys.stderr, mininterval=2.0)
        for k, line in enumerate(maker.lines(args.lines)):
            harness.run(line)
            if k % 500 == 499:
                bar.update(500)
                bar.set_postfix(failures=len(harness.failures), refresh=False)
        bar.close()
        wall = time.perf_counter() - t0
    crashes = [f for f in harness.failures if f.kind == "crash"]
    slow = [f for f in harness.failures if f.kind == "slow"]
    print(f"{harness.lines_run} lines in {wall:.0f} s ({harness.lines_run / wall:.0f} lines/s), seed {args.seed}: "
          f"{len(crashes)} crashes, {len(slow)} lines over {args.budget:g} s; slowest {harness.slowest_s:.3f} s; "
          f"{harness.heavy_lines} lines made over 10,000 aircraft (no time budget)")
    for failure in harness.failures[:20]:
        print(f"{failure.kind}: {failure.detail}\n    {failure.line!r}")
    return 1 if harness.failures else 0


if __name__ == "__main__":
    sys.exit(main())
