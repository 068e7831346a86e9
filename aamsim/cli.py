"""The ``aamsim`` command line."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Any

import click

from aamsim.units import UnitParseError, parse_time


def _time_option(value: str | None) -> float | None:
    if value is None:
        return None
    try:
        return parse_time(value)
    except UnitParseError as exc:
        raise click.BadParameter(str(exc)) from None


class _Progress:
    """A tqdm bar on a terminal; otherwise a line every 10 s of wall time."""

    def __init__(self, total_s: float | None, quiet: bool):
        self.quiet = quiet
        self.bar = None
        self.last_line = time.perf_counter()
        if quiet:
            return
        if sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=round(total_s) if total_s else None, unit="sim s", file=sys.stderr,
                            dynamic_ncols=True, leave=False)

    def __call__(self, sim: Any, wall_s: float) -> None:
        if self.quiet:
            return
        speedup = sim.simt / wall_s if wall_s > 0 else math.inf
        if self.bar is not None:
            self.bar.n = round(sim.simt)
            self.bar.set_postfix(airborne=sim.traffic.n, speedup=f"{speedup:.0f}x", refresh=False)
            self.bar.refresh()
        elif time.perf_counter() - self.last_line >= 10.0:
            self.last_line = time.perf_counter()
            click.echo(f"  sim {sim.simt:9.0f} s  airborne {sim.traffic.n:5d}  speed-up {speedup:7.0f}x", err=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


@click.group()
@click.version_option(package_name="aamsim")
def main() -> None:
    """aamsim: a BlueSky-compatible, headless, fast-time air-traffic simulator."""


@main.command()
@click.argument("scenario")
@click.option("--until", "until", default=None, help="Stop at this sim time (seconds or HH:MM:SS).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Run directory (default runs/<scenario>-<timestamp>/).")
@click.option("--dt", type=float, default=0.05, show_default=True, help="Time step [s].")
@click.option("--seed", type=int, default=None, help="Random seed (MCRE and seeded models).")
@click.option("--strict", is_flag=True, help="Validate the whole file first; exit 2 listing all errors.")
@click.option("--quiet", is_flag=True, help="No progress bar and no summary.")
@click.option("--log-period", type=float, default=1.0, show_default=True,
              help="Trajectory sample period [s]; 0 disables trajectories.csv.")
@click.option("--plugin", "plugins", multiple=True, help="Load a plugin (repeatable).")
@click.option("--delete-on-arrival", is_flag=True, help="Aircraft delete themselves at the end of their route.")
@click.option("--metrics", default="safety,operational", show_default=True,
              help="Metric groups to report (comma separated).")
@click.option("--threads", type=int, default=1, show_default=True,
              help="Numba threads stepping the traffic (same results; helps from a few hundred aircraft).")
def run(scenario: str, until: str | None, out_dir: Path | None, dt: float, seed: int | None, strict: bool,
        quiet: bool, log_period: float, plugins: tuple[str, ...], delete_on_arrival: bool, metrics: str,
        threads: int) -> None:
    """Simulate SCENARIO headless, as fast as possible, and write a run directory.

    SCENARIO is a path, or the name of a scenario shipped with aamsim
    (e.g. scn/nyc_day.scn).
    """
    from aamsim.runner import RunConfig, ScenarioNotFound, StrictValidationFailed, run_scenario
    from aamsim.scenarios import resolve_scenario

    if dt <= 0:
        raise click.BadParameter("--dt must be positive")
    if log_period < 0:
        raise click.BadParameter("--log-period cannot be negative")
    import numba

    available = int(numba.config.NUMBA_NUM_THREADS)  # type: ignore[attr-defined]
    if not 1 <= threads <= available:
        raise click.BadParameter(f"--threads must be between 1 and {available}")
    until_s = _time_option(until)
    groups = tuple(g.strip() for g in metrics.split(",") if g.strip())
    cfg = RunConfig(scenario, out_dir, until_s, dt, seed, strict, log_period, plugins, delete_on_arrival, groups,
                    threads)

    def listener(msg: Any) -> None:
        if msg.kind in ("error", "warning"):
            click.echo(str(msg), err=True)
        elif not quiet and msg.kind in ("echo", "note"):
            click.echo(str(msg), err=True)

    path = resolve_scenario(scenario)
    total = until_s
    progress = _Progress(total, quiet)
    try:
        result = run_scenario(cfg, progress=progress, listener=listener)
    except ScenarioNotFound as exc:
        progress.close()
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except StrictValidationFailed as exc:
        progress.close()
        for err in exc.errors:
            click.echo(str(err), err=True)
        click.echo(f"{path}: {len(exc.errors)} error(s); nothing simulated (--strict)", err=True)
        sys.exit(2)
    except Exception:
        progress.close()
        raise
    progress.close()
    s = result.summary
    if not quiet:
        click.echo(
            f"{s['scenario']}: {s['flights_created']} flights created, {s['flights_arrived']} arrived, "
            f"{s['aircraft_at_end']} still flying\n"
            f"sim time {s['sim_time_s']:.1f} s in {s['wall_time_s']:.2f} s wall "
            f"(speed-up {s['speedup']:.0f}x, {s['aircraft_steps_per_s'] or 0:,.0f} aircraft-steps/s)\n"
            f"errors: {s['errors']}; results in {result.out_dir}"
        )


@main.command()
@click.option("--group", default=None, help="Only this group (traffic, autopilot, route, conditional, ...).")
def commands(group: str | None) -> None:
    """List the stack commands with their arguments and help."""
    from aamsim.simulation import Simulation

    sim = Simulation(use_bluesky_navdata=False)
    for spec in sim.commands.specs():
        if group and spec.group != group.lower():
            continue
        aliases = f"  (also {', '.join(spec.aliases)})" if spec.aliases else ""
        click.echo(f"{spec.usage}{aliases}")
        click.echo(f"    [{spec.group}] {spec.summary}")
