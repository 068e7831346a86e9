"""Record BlueSky's trajectories for the conformance suite.

Runs every ``tests/conformance/scenarios/*.scn`` (or the files given) in
bluesky-simulator, headless and detached, and writes the state of every
aircraft at fixed sample times to ``tests/conformance/reference/<name>.json``.
The conformance test (``tests/conformance/test_conformance.py``) compares
aamsim against these committed files, so it does not need BlueSky installed;
regenerating them does::

    python bench/bluesky_reference.py                 # all scenarios
    python bench/bluesky_reference.py path/to/x.scn   # some of them

Sample times come from a header comment in the scenario file::

    # conformance: until=600 every=5

that is ``every``, ``2*every``, ... up to ``until`` seconds (an optional
``extra=12.5,30.05`` adds more). The state at time T is the one after the
simulation step that reached T, before the commands due at T run.

BlueSky keeps its whole state in process globals, so each scenario runs in a
fresh subprocess (``--worker``) with its own work directory, whose
``scenario/`` folder holds a copy of the scenario folder (PCALL looks there).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENARIO_DIR = ROOT / "tests" / "conformance" / "scenarios"
REFERENCE_DIR = ROOT / "tests" / "conformance" / "reference"

# Quantities recorded per aircraft (BlueSky's traffic arrays, SI units, degrees).
FIELDS = ("lat", "lon", "alt", "tas", "cas", "gs", "hdg", "trk", "vs", "distflown")
# Decimals kept in the JSON: 1e-9 deg is 0.1 mm, 1e-6 m or m/s is far below any tolerance.
DECIMALS = {"lat": 9, "lon": 9, "hdg": 6, "trk": 6}
DEFAULT_DECIMALS = 6

_HEADER = re.compile(r"^\s*#\s*conformance:(.*)$", re.IGNORECASE | re.MULTILINE)


def sample_times(text: str) -> list[float]:
    """Sample times [s] declared by a scenario's ``# conformance:`` header."""
    match = _HEADER.search(text)
    if match is None:
        raise ValueError("no '# conformance: until=... every=...' header")
    options = dict(item.split("=", 1) for item in match.group(1).split())
    until = float(options["until"])
    every = float(options.get("every", "5"))
    count = round(until / every)
    times = {round(k * every, 6) for k in range(1, count + 1)}
    for extra in options.get("extra", "").split(","):
        if extra.strip():
            times.add(round(float(extra), 6))
    return sorted(times)


def _run_bluesky(scenario: Path, workdir: Path, times: list[float]) -> dict:
    """Run one scenario in this process (the worker); returns the reference record."""
    with contextlib.redirect_stdout(io.StringIO()):
        import bluesky as bs

        bs.init(mode="sim", detached=True, workdir=str(workdir))
    messages: list[str] = []

    def capture(topic, data=None, *args, **kwargs):
        # Detached BlueSky drops ECHO text; keep its errors (a non-zero flag) for the record.
        if topic in ("ECHO", b"ECHO") and isinstance(data, dict) and data.get("flags", 0):
            messages.append(str(data.get("text", "")))

    bs.net.send = capture
    # BlueSky's own loader: drops short lines, strips comments, sorts by time.
    lines = bs.stack.simstack.readscn(str(scenario))
    bs.stack.set_scendata([t for t, _ in lines], [c for _, c in lines])
    samples = []
    for t in times:
        while bs.sim.simt < t - 1e-9:
            bs.sim.step()
        row: dict = {"t": round(float(bs.sim.simt), 6), "ids": list(bs.traf.id)}
        for name in FIELDS:
            values = getattr(bs.traf, name)
            digits = DECIMALS.get(name, DEFAULT_DECIMALS)
            row[name] = [round(float(v), digits) for v in values]
        row["swlnav"] = [bool(v) for v in bs.traf.swlnav]
        row["swvnav"] = [bool(v) for v in bs.traf.swvnav]
        samples.append(row)
    return {
        "scenario": scenario.name,
        "generator": "bench/bluesky_reference.py",
        "bluesky_version": _bluesky_version(),
        "dt": float(bs.sim.simdt),
        "fields": list(FIELDS),
        "samples": samples,
        "bluesky_messages": [m for m in messages if m.strip()],
    }


def _bluesky_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("bluesky-simulator")
    except PackageNotFoundError:
        return "unknown"


def _worker(scenario: Path, out: Path) -> None:
    times = sample_times(scenario.read_text())
    with tempfile.TemporaryDirectory(prefix="bluesky-ref-") as tmp:
        workdir = Path(tmp)
        shutil.copytree(scenario.parent, workdir / "scenario")
        record = _run_bluesky(workdir / "scenario" / scenario.name, workdir, times)
    out.write_text(_dump(record))


def _dump(record: dict) -> str:
    """JSON with one sample per line: readable diffs, modest size."""
    head = {k: v for k, v in record.items() if k != "samples"}
    lines = ["{"]
    for key, value in head.items():
        lines.append(f"  {json.dumps(key)}: {json.dumps(value)},")
    lines.append('  "samples": [')
    samples = record["samples"]
    for k, row in enumerate(samples):
        if any(isinstance(v, float) and not math.isfinite(v) for vs in row.values() if isinstance(vs, list)
               for v in vs):
            raise ValueError(f"non-finite value at t={row['t']}")
        lines.append("    " + json.dumps(row, separators=(",", ":")) + ("," if k + 1 < len(samples) else ""))
    lines.append("  ]")
    lines.append("}")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenarios", nargs="*", type=Path, help="scenario files (default: all conformance scenarios)")
    parser.add_argument("--out", type=Path, default=REFERENCE_DIR, help="folder for the <name>.json references")
    parser.add_argument("--worker", nargs=2, type=Path, metavar=("SCN", "JSON"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        _worker(args.worker[0].resolve(), args.worker[1])
        return 0
    scenarios = args.scenarios or sorted(SCENARIO_DIR.glob("*.scn"))
    args.out.mkdir(parents=True, exist_ok=True)
    failed = 0
    for scn in scenarios:
        out = args.out / f"{scn.stem}.json"
        proc = subprocess.run(
            [sys.executable, __file__, "--worker", str(scn.resolve()), str(out)],
            capture_output=True,
            text=True,
            check=False,
        )
        if proc.returncode != 0:
            failed += 1
            sys.stderr.write(f"{scn.name}: BlueSky run failed\n{proc.stderr}\n")
            continue
        samples = json.loads(out.read_text())["samples"]
        sys.stdout.write(f"{scn.name}: {len(samples)} samples -> {out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}\n")
        if proc.stderr.strip():
            # Tracebacks of BlueSky command errors land on stderr: show them.
            sys.stderr.write(f"{scn.name}: BlueSky stderr:\n{proc.stderr}\n")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
