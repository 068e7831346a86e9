"""Peak memory of ``uam2scn`` on a large schedule (issue 19: a 100 MB file peaked at 3.9 GB).

Writes a schedule of ``--rows`` rows (default 954,429, about 100 MB: copies of the synthetic
New York day with distinct flight ids), converts it with ``python -m uamtoolkit_import`` in a
child process and prints the child's peak resident set size (``ru_maxrss``) and wall time.

    python bench/bench_uam2scn_memory.py [--rows N] [--keep DIR]
"""

from __future__ import annotations

import argparse
import io
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def write_big_schedule(path: Path, rows: int) -> int:
    """``rows`` flight rows (the synthetic day repeated with new flight ids); returns the file size [B]."""
    from uamtoolkit_import.netfile import nyc_network
    from uamtoolkit_import.schedule import write_schedule
    from uamtoolkit_import.synth import synthesize

    buf = io.StringIO()
    write_schedule(synthesize(nyc_network()).flights, buf)
    header, *day = buf.getvalue().splitlines()
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(header + "\n")
        written, copy = 0, 0
        while written < rows:
            # Distinct flight ids: C000UAM0001, C001UAM0001, ...
            fh.writelines(f"C{copy:03d}{line}\n" for line in day[: rows - written])
            written += min(len(day), rows - written)
            copy += 1
    return path.stat().st_size


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", type=int, default=954_429)
    ap.add_argument("--keep", type=Path, default=None, help="write the files here (default: a temporary directory)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = args.keep or Path(tmp)
        d.mkdir(parents=True, exist_ok=True)
        src, out = d / "big_schedule.csv", d / "big.scn"
        size = write_big_schedule(src, args.rows)
        env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "uamtoolkit_import", str(src), "-o", str(out)], env=env,
                              capture_output=True, text=True, check=False)
        wall = time.perf_counter() - t0
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0  # Linux: KiB
        print(f"schedule: {args.rows:,} rows, {size / 1e6:.1f} MB")
        print(f"uam2scn: exit {proc.returncode}, {wall:.1f} s, peak RSS {peak_mb:,.0f} MB")
        print(proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else proc.stdout.strip())


if __name__ == "__main__":
    main()
