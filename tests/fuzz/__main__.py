"""``python -m tests.fuzz --lines 1000000 [--seed 0] [--target scenario|batch|uam2scn|viewer]``: the long
fuzzing runs, with progress and a summary.

``scenario`` (the default) runs scenario lines in simulations (:mod:`tests.fuzz.scenario`); ``batch`` plans
(and now and then runs) BlueSky batch files; ``uam2scn`` converts networks and schedules with hostile fields
(:mod:`tests.fuzz.files`); ``viewer`` sends control messages and connections to two real web viewers
(:mod:`tests.fuzz.viewer_ws`). The exit status is 1 when a case failed: a crash, a wrong answer, or a case
that was slow (or hung) and is slow again when rerun alone. A case slow only among the others (a loaded
machine) is counted in the summary, not failed.
"""

from __future__ import annotations

import argparse
import json
import logging
import resource
import sys
import tempfile
import time
from pathlib import Path

from tests.fuzz.scenario import Failure, Harness, LineMaker

TARGETS = ("scenario", "batch", "uam2scn", "viewer")


def peak_rss_mb() -> float:
    """The largest resident size this process has had [MB]."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _scenario(args: argparse.Namespace) -> tuple[int, list[Failure], str]:
    from tqdm import tqdm

    with tempfile.TemporaryDirectory() as folder:
        harness = Harness(Path(folder), budget_s=args.budget, log_path=args.report)
        maker = LineMaker(args.seed)
        bar = tqdm(total=args.lines, unit="line", file=sys.stderr, mininterval=2.0)
        for k, line in enumerate(maker.lines(args.lines)):
            harness.run(line)
            if k % 500 == 499:
                bar.update(500)
                bar.set_postfix(failures=len(harness.failures), refresh=False)
        bar.close()
    notes = (f"slowest {harness.slowest_s:.3f} s; {len(harness.unconfirmed_slow)} lines over {args.budget:g} s "
             f"among the others but not alone; {harness.heavy_lines} lines made over 10,000 aircraft (no time "
             "budget)")
    return harness.lines_run, harness.failures, notes


def _files(args: argparse.Namespace) -> tuple[int, list[Failure], str]:
    from tests.fuzz.files import fuzz_batch, fuzz_uam2scn

    result = fuzz_batch(args.lines, args.seed) if args.target == "batch" else fuzz_uam2scn(args.lines, args.seed)
    return result.cases, result.failures, f"{result.refused} refused by the tool with its own error"


def _viewer(args: argparse.Namespace) -> tuple[int, list[Failure], str]:
    from tests.fuzz.viewer_ws import fuzz_viewer

    result = fuzz_viewer(args.lines, args.seed)
    return result.cases, result.failures, (
        f"{result.messages} control messages ({result.error_replies} answered with an error), "
        f"{result.connections} connections ({result.refused_connections} refused); {result.unconfirmed_hangs} "
        "answers late among the others but not on a fresh connection")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--lines", type=int, default=100_000, help="cases to run (lines, files, messages)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--target", choices=TARGETS, default="scenario")
    parser.add_argument("--budget", type=float, default=1.0, help="seconds a scenario line may take")
    parser.add_argument("--report", type=Path, default=None, help="append failures here as JSON lines")
    args = parser.parse_args(argv)
    logging.disable(logging.CRITICAL)
    if args.report is not None:
        args.report.write_text("")
    t0 = time.perf_counter()
    run = {"scenario": _scenario, "batch": _files, "uam2scn": _files, "viewer": _viewer}[args.target]
    cases, failures, notes = run(args)
    wall = time.perf_counter() - t0
    if args.report is not None and args.target != "scenario":  # the scenario harness appends as it goes
        with open(args.report, "a", encoding="utf-8") as fh:
            fh.writelines(json.dumps(f.__dict__) + "\n" for f in failures)
    crashes = sum(1 for f in failures if f.kind == "crash")
    print(f"{args.target}: {cases} cases in {wall:.0f} s ({cases / max(wall, 1e-9):.0f}/s), seed {args.seed}: "
          f"{crashes} crashes, {len(failures) - crashes} other failures (slow or hung again alone, wrong "
          f"answers); {notes}; peak RSS {peak_rss_mb():.0f} MB")
    for failure in failures[:20]:
        print(f"{failure.kind}: {failure.detail}\n    {failure.line!r}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
