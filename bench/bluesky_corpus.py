"""Run BlueSky's own scenario corpus in BlueSky and in aamsim, side by side.

For every loadable scenario file of BlueSky's ``scenario/`` folder (GitHub:
TUDelft-CNS-ATM/bluesky) it prints the errors each simulator reports, the wall
time of each, and, for the aircraft both have at the end, how far apart they
are as a fraction of the distance flown::

    git clone --depth 1 https://github.com/TUDelft-CNS-ATM/bluesky /tmp/bluesky
    python bench/bluesky_corpus.py --corpus /tmp/bluesky/scenario             # all files, 120 s each
    python bench/bluesky_corpus.py --corpus DIR --only 'ASAS/*' --until 60   # some of them
    python bench/bluesky_corpus.py --corpus DIR --json out.json --markdown   # keep the table

Without ``--corpus`` the ``scenario`` folder of an installed BlueSky is used
(the bluesky-simulator wheel ships none).

BlueSky runs headless, each file in a fresh process (``--bluesky-worker``,
``--jobs`` of them at a time), as a user starts it on one scenario file.
``--one-process`` runs all files in one process instead, one after the other
as its ``IC`` does (``sim.reset()`` and its own ``readscn``; a crash restarts
the worker at the next file): faster, but BlueSky's reset keeps some settings
of the file before (the conflict-resolution method and its settings, for
one), so a file's result can depend on the file run before it (MOV/MOV02.scn
ended 6.8 km away from its fresh-process positions). Its error text is caught where BlueSky
sends it (``bs.net.send`` of ECHO with an error flag, lines its reader skips
with ``except this:``, exceptions out of a step), and the commands it
forwards to a GUI are split into the GUI's own commands (PAN, ZOOM, ...) and
unknown ones. A file is *clean in BlueSky* when it has neither errors nor
unknown forwarded commands. aamsim runs each file in a fresh
:class:`aamsim.Simulation` with BlueSky's navigation data; its errors are the
messages of kind ``error``. HOLD does not stop either side (aamsim run goes on
after HOLD; the BlueSky worker answers it with OP).

Loadable files are those ending in lower-case ``.scn``: BlueSky forces the
suffix to lower case, so ``*.SCN`` files do not load on Linux.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import fnmatch
import io
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
POS_FRACTION = 0.01  # agreement target: within 1 % of the distance flown
POS_FLOOR_M = 1.0  # and never stricter than a metre (aircraft that barely moved)
MAX_MESSAGES = 5  # error texts kept per file and side


@dataclass
class SideResult:
    """What one simulator did with one file."""

    errors: list[str] = field(default_factory=list)
    error_count: int = 0
    unknown_forwarded: list[str] = field(default_factory=list)  # BlueSky only
    wall_s: float = 0.0
    simt: float = 0.0
    crashed: str = ""
    # acid -> (lat, lon, alt, distflown) at the end
    aircraft: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)

    def add_error(self, text: str) -> None:
        self.error_count += 1
        if len(self.errors) < MAX_MESSAGES:
            self.errors.append(" ".join(text.split())[:300])

    @property
    def clean(self) -> bool:
        return not self.error_count and not self.unknown_forwarded and not self.crashed


# ----------------------------------------------------------------- the corpus


def default_corpus() -> Path | None:
    """The ``scenario`` folder of an installed BlueSky, if there is one."""
    try:
        import bluesky
    except ImportError:
        return None
    base = Path(bluesky.__file__).resolve().parent
    for candidate in (base / "scenario", base / "resources" / "scenario", base.parent / "scenario"):
        if candidate.is_dir() and any(candidate.rglob("*.scn")):
            return candidate
    return None


def corpus_files(corpus: Path, patterns: list[str]) -> list[str]:
    """Loadable files (lower-case ``.scn``), relative to the corpus, sorted."""
    names = sorted(p.relative_to(corpus).as_posix() for p in corpus.rglob("*") if p.suffix == ".scn" and p.is_file())
    if patterns:
        names = [n for n in names if any(fnmatch.fnmatch(n, pat) for pat in patterns)]
    return names


def gui_commands() -> set[str]:
    """Command names BlueSky's GUIs define (read from its ``ui`` sources, as BlueSky finds its plugins).

    A command a scenario forwards to the GUI is fine when the GUI knows it (PAN, ZOOM, ...).
    """
    import bluesky

    names: set[str] = set()
    for path in (Path(bluesky.__file__).parent / "ui").rglob("*.py"):
        tree = ast.parse(path.read_text(errors="replace"))
        for node in ast.walk(tree):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for deco in node.decorator_list:
                target = deco.func if isinstance(deco, ast.Call) else deco
                dname = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
                if dname not in ("command", "commandgroup"):
                    continue
                name = node.name.upper()
                if isinstance(deco, ast.Call):
                    for kw in deco.keywords:
                        if kw.arg == "name" and isinstance(kw.value, ast.Constant):
                            name = str(kw.value.value).upper()
                        if kw.arg == "aliases" and isinstance(kw.value, (ast.Tuple, ast.List)):
                            names.update(str(e.value).upper() for e in kw.value.elts if isinstance(e, ast.Constant))
                names.add(name)
    names.update({"ZOOM", "PAN"})
    return names


# -------------------------------------------------------------- BlueSky side


class _Timeout(Exception):
    pass


def _bluesky_worker(corpus: Path, names: list[str], until: float, timeout_s: float, out_path: Path) -> None:
    """Run files in BlueSky in this process, one JSON line per file (flushed as it goes)."""
    workdir = Path(tempfile.mkdtemp(prefix="bluesky-corpus-"))
    try:
        _bluesky_files(corpus, names, until, timeout_s, out_path, workdir)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


def _bluesky_files(corpus: Path, names: list[str], until: float, timeout_s: float, out_path: Path,
                   workdir: Path) -> None:
    os.chdir(workdir)
    shutil.copytree(corpus, workdir / "scenario")
    with contextlib.redirect_stdout(io.StringIO()):
        import bluesky as bs

        bs.init(mode="sim", detached=True, workdir=str(workdir))
    from bluesky.stack import simstack

    gui = gui_commands()
    current = SideResult()

    def send(topic, data=None, *args, **kwargs):
        topic = topic.decode() if isinstance(topic, bytes) else str(topic)
        if topic == "ECHO" and isinstance(data, dict) and data.get("flags", 0):
            current.add_error(str(data.get("text", "")))
        elif topic == "STACK" and isinstance(data, str):
            for line in data.split(";"):
                word = line.strip().split(" ")[0].split(",")[0].upper()
                zoom_keys = word[:1] in ("+", "=", "-")  # the client reads ++/-- as ZOOM
                if word and word not in gui and not zoom_keys and line.strip() not in current.unknown_forwarded:
                    current.unknown_forwarded.append(line.strip()[:200])

    bs.net.send = send

    def alarm(signum, frame):
        raise _Timeout()

    signal.signal(signal.SIGALRM, alarm)
    with open(out_path, "a") as out:
        for name in names:
            current = SideResult()
            captured = io.StringIO()
            t0 = time.perf_counter()
            signal.setitimer(signal.ITIMER_REAL, timeout_s)
            try:
                with contextlib.redirect_stdout(captured), contextlib.redirect_stderr(io.StringIO()):
                    bs.sim.reset()
                    lines = simstack.readscn(name)
                    bs.stack.set_scendata([t for t, _ in lines], [c for _, c in lines])
                    while bs.sim.simt < until - 1e-9 and bs.sim.state != bs.END:
                        if bs.sim.state == bs.HOLD:
                            bs.sim.op()
                        bs.sim.step()
            except _Timeout:
                current.crashed = f"timeout after {timeout_s:.0f} s wall"
            except Exception as exc:  # BlueSky's own failures are what this records
                current.crashed = f"{type(exc).__name__}: {exc}"[:300]
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
            current.wall_s = time.perf_counter() - t0
            current.simt = float(bs.sim.simt)
            for line in captured.getvalue().splitlines():
                if line.startswith("except this:") or "value error" in line:
                    current.add_error(line)
            try:
                for i, acid in enumerate(bs.traf.id):
                    current.aircraft[acid] = (float(bs.traf.lat[i]), float(bs.traf.lon[i]), float(bs.traf.alt[i]),
                                              float(bs.traf.distflown[i]))
            except Exception as exc:  # a broken traffic state after a crash
                current.crashed = current.crashed or f"state unreadable: {exc}"
            out.write(json.dumps({"name": name, **asdict(current)}) + "\n")
            out.flush()


def _side_result(record: dict) -> SideResult:
    """A :class:`SideResult` from its JSON record (a worker's line or the cache; a ``name`` key is dropped)."""
    fields = {k: v for k, v in record.items() if k != "name"}
    fields["aircraft"] = {k: tuple(v) for k, v in fields["aircraft"].items()}
    return SideResult(**fields)


def _bluesky_fresh(corpus: Path, name: str, until: float, timeout_s: float, tmp: Path) -> SideResult:
    """One file in a fresh BlueSky process."""
    safe = name.replace("/", "__")
    listing, out = tmp / f"{safe}.names.json", tmp / f"{safe}.jsonl"
    listing.write_text(json.dumps([name]))
    proc = subprocess.run(
        [sys.executable, __file__, "--bluesky-worker", str(corpus), str(listing), str(out),
         "--until", str(until), "--timeout", str(timeout_s)],
        capture_output=True, text=True, check=False,
    )
    if out.exists() and out.read_text().strip():
        return _side_result(json.loads(out.read_text().splitlines()[0]))
    tail = (proc.stderr or "").strip().splitlines()[-1:] or [f"exit status {proc.returncode}"]
    return SideResult(crashed=f"BlueSky process died: {tail[0][:200]}")


def run_bluesky_per_file(corpus: Path, names: list[str], until: float, timeout_s: float,
                         jobs: int) -> dict[str, SideResult]:
    """Every file in its own fresh BlueSky process, ``jobs`` at a time, with progress on stderr."""
    from concurrent.futures import ThreadPoolExecutor, as_completed

    results: dict[str, SideResult] = {}
    with tempfile.TemporaryDirectory(prefix="bluesky-corpus-out-") as tmp, \
            ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = {pool.submit(_bluesky_fresh, corpus, name, until, timeout_s, Path(tmp)): name for name in names}
        for k, future in enumerate(as_completed(futures), 1):
            results[futures[future]] = future.result()
            sys.stderr.write(f"\rBlueSky {k}/{len(names)} {futures[future][:60]:60s}")
    sys.stderr.write("\n")
    return results


def run_bluesky(corpus: Path, names: list[str], until: float, timeout_s: float) -> dict[str, SideResult]:
    """All files in BlueSky, one worker process, restarted after a crash (``--one-process``)."""
    results: dict[str, SideResult] = {}
    pending = list(names)
    with tempfile.TemporaryDirectory(prefix="bluesky-corpus-out-") as tmp:
        out = Path(tmp) / "results.jsonl"
        while pending:
            listing = Path(tmp) / "names.json"
            listing.write_text(json.dumps(pending))
            proc = subprocess.run(
                [sys.executable, __file__, "--bluesky-worker", str(corpus), str(listing), str(out),
                 "--until", str(until), "--timeout", str(timeout_s)],
                capture_output=True, text=True, check=False,
            )
            if out.exists():
                for line in out.read_text().splitlines():
                    record = json.loads(line)
                    results[record["name"]] = _side_result(record)
            pending = [n for n in names if n not in results]
            if pending:
                # The worker died inside the first pending file: record that and go on after it.
                dead = pending.pop(0)
                tail = (proc.stderr or "").strip().splitlines()[-1:] or [f"exit status {proc.returncode}"]
                results[dead] = SideResult(crashed=f"BlueSky process died: {tail[0][:200]}")
                sys.stderr.write(f"BlueSky died on {dead}; restarting at the next file\n")
    return results


# --------------------------------------------------------------- aamsim side


def run_aamsim(corpus: Path, name: str, until: float) -> SideResult:
    """One file in a fresh aamsim Simulation (BlueSky's navigation data, corpus root on the search path)."""
    from aamsim import Simulation
    from aamsim.traffic import fields as f

    result = SideResult()
    t0 = time.perf_counter()
    sim = Simulation(seed=0)
    sim.files.search_path.append(corpus)  # BlueSky resolves PCALL names against its scenario folder
    try:
        sim.load_scenario(corpus / name)
        sim.run(until_s=until)
    except Exception as exc:  # an aamsim crash is a finding: record it, go on with the next file
        result.crashed = f"{type(exc).__name__}: {exc}"[:300]
    result.wall_s = time.perf_counter() - t0
    result.simt = sim.simt
    for msg in sim.reporter.errors():
        result.add_error(str(msg).replace(str(corpus) + os.sep, ""))
    F = sim._traffic.F
    for i, acid in enumerate(sim.view.ids):
        result.aircraft[acid] = (float(F[f.LAT, i]), float(F[f.LON, i]), float(F[f.ALT, i]), float(F[f.DISTFLOWN, i]))
    return result


def _warm_up_aamsim() -> None:
    """Load aamsim's compiled kernels once, so that the first file's wall time is its own."""
    from aamsim import Simulation

    sim = Simulation(seed=0)
    sim.stack("CRE WARM B744 0 0 90 FL100 250; ADDWPT WARM 0.1 0.1")
    sim.run(until_s=2.0)


# ---------------------------------------------------------------- comparison


@dataclass
class Comparison:
    name: str
    bluesky: SideResult
    aamsim: SideResult
    common: int = 0
    worst_acid: str = ""
    worst_m: float = 0.0
    worst_fraction: float = 0.0  # of BlueSky's distance flown
    within: bool = True
    only_bluesky: list[str] = field(default_factory=list)
    only_aamsim: list[str] = field(default_factory=list)


def compare(name: str, bsr: SideResult, aar: SideResult) -> Comparison:
    from aamsim.geo import geodesic_inverse

    cmp = Comparison(name, bsr, aar)
    common = sorted(set(bsr.aircraft) & set(aar.aircraft))
    cmp.only_bluesky = sorted(set(bsr.aircraft) - set(aar.aircraft))
    cmp.only_aamsim = sorted(set(aar.aircraft) - set(bsr.aircraft))
    cmp.common = len(common)
    for acid in common:
        lat0, lon0, _, flown = bsr.aircraft[acid]
        lat1, lon1, _, _ = aar.aircraft[acid]
        dist = geodesic_inverse(lat0, lon0, lat1, lon1)[1] if (lat0, lon0) != (lat1, lon1) else 0.0
        if not math.isfinite(dist):
            dist = math.inf
        fraction = dist / flown if flown > 0 else (0.0 if dist <= POS_FLOOR_M else math.inf)
        if dist > POS_FLOOR_M and dist > POS_FRACTION * flown:
            cmp.within = False
        if dist > cmp.worst_m or not cmp.worst_acid:
            cmp.worst_m, cmp.worst_fraction, cmp.worst_acid = dist, fraction, acid
    return cmp


def _first(messages: list[str]) -> str:
    return messages[0][:110] if messages else ""


def print_report(results: list[Comparison], until: float, markdown: bool, out=sys.stdout) -> dict:
    """The per-file table and the totals; returns the totals."""
    bs_clean = [c for c in results if c.bluesky.clean]
    aam_errors_on_clean = [c for c in bs_clean if c.aamsim.error_count or c.aamsim.crashed]
    both = [c for c in bs_clean if not (c.aamsim.error_count or c.aamsim.crashed)]
    compared = [c for c in both if c.common]
    outside = [c for c in compared if not c.within]
    totals = {
        "files": len(results),
        "until_s": until,
        "bluesky_clean": len(bs_clean),
        "aamsim_errors_on_bluesky_clean": len(aam_errors_on_clean),
        "both_clean": len(both),
        "compared": len(compared),
        "within_1pct": len(compared) - len(outside),
        "bluesky_wall_s": round(sum(c.bluesky.wall_s for c in results), 1),
        "aamsim_wall_s": round(sum(c.aamsim.wall_s for c in results), 1),
        "bluesky_wall_s_both_clean": round(sum(c.bluesky.wall_s for c in both), 1),
        "aamsim_wall_s_both_clean": round(sum(c.aamsim.wall_s for c in both), 1),
    }
    w = out.write
    if markdown:
        w("| file | BlueSky errors | BlueSky unknown cmds | aamsim errors | BlueSky s | aamsim s | common a/c | "
          "worst position error |\n|---|---|---|---|---|---|---|---|\n")
    for c in results:
        b, a = c.bluesky, c.aamsim
        berr = f"{b.error_count}" + (f" ({b.crashed})" if b.crashed else "")
        aerr = f"{a.error_count}" + (f" ({a.crashed})" if a.crashed else "")
        worst = f"{c.worst_m:.1f} m ({100 * c.worst_fraction:.3g} %) {c.worst_acid}" if c.common else "-"
        if markdown:
            w(f"| {c.name} | {berr} | {len(b.unknown_forwarded)} | {aerr} | {b.wall_s:.2f} | {a.wall_s:.2f} | "
              f"{c.common} | {worst} |\n")
        else:
            w(f"{c.name}\n  BlueSky: {berr} errors, {len(b.unknown_forwarded)} unknown forwarded, {b.wall_s:.2f} s"
              f"{'  ' + _first(b.errors) if b.errors else ''}"
              f"{'  fwd: ' + b.unknown_forwarded[0][:60] if b.unknown_forwarded else ''}\n"
              f"  aamsim:  {aerr} errors, {a.wall_s:.2f} s{'  ' + _first(a.errors) if a.errors else ''}\n"
              f"  end: {c.common} common aircraft, worst {worst}"
              f"{f', only BlueSky {len(c.only_bluesky)}' if c.only_bluesky else ''}"
              f"{f', only aamsim {len(c.only_aamsim)}' if c.only_aamsim else ''}\n")
    w("\n")
    w(f"{totals['files']} files, {until:g} s each. BlueSky clean (no error, no unknown command forwarded): "
      f"{totals['bluesky_clean']}; of those aamsim reports errors on {totals['aamsim_errors_on_bluesky_clean']}.\n")
    w(f"Both clean: {totals['both_clean']}; with common aircraft: {totals['compared']}; end positions within "
      f"{100 * POS_FRACTION:g} % of distance flown: {totals['within_1pct']}.\n")
    w(f"Wall time, all files: BlueSky {totals['bluesky_wall_s']} s, aamsim {totals['aamsim_wall_s']} s; "
      f"files both run cleanly: BlueSky {totals['bluesky_wall_s_both_clean']} s, "
      f"aamsim {totals['aamsim_wall_s_both_clean']} s.\n")
    if aam_errors_on_clean:
        w("aamsim errors on files BlueSky runs cleanly:\n")
        for c in aam_errors_on_clean:
            w(f"  {c.name}: {c.aamsim.crashed or _first(c.aamsim.errors)}\n")
    worst = sorted(compared, key=lambda c: -c.worst_fraction)[:10]
    if worst:
        w("Largest end-position differences (fraction of BlueSky's distance flown):\n")
        for c in worst:
            w(f"  {c.name}: {c.worst_acid} {c.worst_m:.1f} m = {100 * c.worst_fraction:.3g} %\n")
    return totals


def _cached_bluesky(path: Path | None, until: float, mode: str) -> dict[str, SideResult]:
    if path is None or not path.exists():
        return {}
    data = json.loads(path.read_text())
    # A cache without a mode is from the one-process runs that came first.
    if data.get("until_s") != until or data.get("mode", "one-process") != mode:
        sys.stderr.write(f"{path}: not BlueSky's results for --until {until:g} in {mode} mode: not used\n")
        return {}
    out = {}
    for name, record in data["files"].items():
        out[name] = _side_result(record)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--corpus", type=Path, help="BlueSky's scenario folder (default: an installed BlueSky's)")
    parser.add_argument("--only", action="append", default=[], help="glob of files to run (relative; repeatable)")
    parser.add_argument("--until", type=float, default=120.0, help="simulated seconds per file (120)")
    parser.add_argument("--timeout", type=float, default=300.0, help="wall seconds per file and side (300)")
    parser.add_argument("--json", type=Path, help="write every result here")
    parser.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    parser.add_argument("--bluesky-cache", type=Path,
                        help="BlueSky's results: read from this JSON file when it exists (same --until), else "
                             "written to it (BlueSky takes most of the time; aamsim changes do not touch it)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="BlueSky processes at a time (default: the number of CPUs)")
    parser.add_argument("--one-process", action="store_true",
                        help="run every file in one BlueSky process (faster; see the module docstring)")
    parser.add_argument("--bluesky-worker", nargs=3, type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.bluesky_worker:
        corpus, listing, out = args.bluesky_worker
        _bluesky_worker(corpus.resolve(), json.loads(listing.read_text()), args.until, args.timeout, out)
        return 0
    corpus = args.corpus or default_corpus()
    if corpus is None or not corpus.is_dir():
        parser.error("no corpus: give --corpus, the scenario/ folder of a clone of TUDelft-CNS-ATM/bluesky")
    corpus = corpus.resolve()
    names = corpus_files(corpus, args.only)
    if not names:
        parser.error(f"no .scn files under {corpus}")
    mode = "one-process" if args.one_process else "per-file"
    sys.stderr.write(f"{len(names)} files; BlueSky first ({mode})...\n")
    _warm_up_aamsim()
    bluesky = _cached_bluesky(args.bluesky_cache, args.until, mode)
    missing = [n for n in names if n not in bluesky]
    if missing:
        if args.one_process:
            bluesky.update(run_bluesky(corpus, missing, args.until, args.timeout))
        else:
            bluesky.update(run_bluesky_per_file(corpus, missing, args.until, args.timeout, args.jobs))
        if args.bluesky_cache:
            args.bluesky_cache.write_text(json.dumps({"until_s": args.until, "mode": mode, "files": {
                k: asdict(v) for k, v in bluesky.items()}}))
    results = []
    for k, name in enumerate(names, 1):
        sys.stderr.write(f"\raamsim {k}/{len(names)} {name[:60]:60s}")
        results.append(compare(name, bluesky[name], run_aamsim(corpus, name, args.until)))
    sys.stderr.write("\n")
    totals = print_report(results, args.until, args.markdown)
    if args.json:
        args.json.write_text(json.dumps({"totals": totals, "files": [asdict(c) for c in results]}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
