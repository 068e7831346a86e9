"""The ``aamsim`` command line."""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import click

from aamsim.errors import CommandError
from aamsim.extras import MissingExtra, require
from aamsim.limits import DEFAULT_LOCAL_MAX_AIRCRAFT, DEFAULT_MAX_AIRCRAFT
from aamsim.units import UnitParseError, parse_time


def _time_option(value: str | None) -> float | None:
    if value is None:
        return None
    try:
        return parse_time(value)
    except UnitParseError as exc:
        raise click.BadParameter(str(exc)) from None


def _viewer_options(fn: Any) -> Any:
    """--host/--port/--allow-host/--open of every command that shows the web viewer."""
    fn = click.option("--open", "open_browser", is_flag=True, help="Open the viewer in the default browser.")(fn)
    fn = click.option("--allow-host", "allow_hosts", multiple=True, metavar="NAME",
                      help="Also answer requests addressed to this host name (IP addresses, localhost and "
                           "--host are always answered; other names are refused against DNS rebinding).")(fn)
    fn = click.option("--port", type=click.IntRange(0, 65535), default=8750, show_default=True,
                      help="Viewer port (0: any free port).")(fn)
    fn = click.option("--host", default="127.0.0.1", show_default=True,
                      help="Viewer address; loopback unless you ask (0.0.0.0 serves every interface).")(fn)
    return fn


def _announce_viewer(url: str, host: str, open_browser: bool) -> None:
    from aamsim.viewer.server import is_loopback

    click.echo(f"viewer: {url}", err=True)
    if not is_loopback(host):
        click.echo(f"warning: the viewer is reachable from other machines on {host}", err=True)
    if open_browser:
        import webbrowser

        webbrowser.open(url)


def _volume(name: str, text: str) -> Any:
    from aamsim.conflicts.service import SeparationVolume

    parts = [p for p in text.split(",") if p.strip()]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise click.BadParameter(f'"{text}": expected RADIUS or RADIUS,HALF_HEIGHT in metres',
                                 param_hint=f"--{name}") from None
    if len(values) not in (1, 2) or any(v <= 0 for v in values):
        raise click.BadParameter(f'"{text}": expected RADIUS or RADIUS,HALF_HEIGHT, positive metres',
                                 param_hint=f"--{name}")
    return SeparationVolume(name, values[0], values[1] if len(values) == 2 else None)


class _Progress:
    """A tqdm bar on a terminal; otherwise a line every 10 s of wall time."""

    def __init__(self, total_s: float | None, quiet: bool):
        self.quiet = quiet
        self.bar = None
        self.previous: tuple[float, float] | None = None  # (sim s, wall s) at the last report
        self.last_line = time.perf_counter()
        if quiet:
            return
        if sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=round(total_s) if total_s else None, unit="sim s", file=sys.stderr,
                            dynamic_ncols=True, leave=False)

    def speedup_text(self, simt: float, wall_s: float) -> str:
        """Sim seconds per wall second since the previous report; blank at the first report, whose
        interval holds the start-up (compiling, reading the scenario) and would show as 0x."""
        previous, self.previous = self.previous, (simt, wall_s)
        if previous is None:
            return ""
        dsim, dwall = simt - previous[0], wall_s - previous[1]
        return f"{dsim / dwall:.0f}x" if dwall > 0 else ""

    def __call__(self, sim: Any, wall_s: float) -> None:
        if self.quiet:
            return
        speedup = self.speedup_text(sim.simt, wall_s)
        if self.bar is not None:
            self.bar.n = round(sim.simt)
            self.bar.set_postfix(airborne=sim.view.n, speedup=speedup, refresh=False)
            self.bar.refresh()
        elif time.perf_counter() - self.last_line >= 10.0:
            self.last_line = time.perf_counter()
            click.echo(f"  sim {sim.simt:9.0f} s  airborne {sim.view.n:5d}  speed-up {speedup:>7}", err=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class _Commands(click.Group):
    """The ``aamsim`` group: a feature whose extra is not installed ends in one line naming it (exit 2)."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except MissingExtra as exc:
            click.echo(f"error: {exc}", err=True)
            ctx.exit(2)


@click.group(cls=_Commands)
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
@click.option("--nmac", default="150", show_default=True,
              help="NMAC volume [m]: RADIUS (sphere, 3-D) or RADIUS,HALF_HEIGHT (cylinder).")
@click.option("--lowc", default="450", show_default=True,
              help="LoWC volume [m]: RADIUS (sphere, 3-D) or RADIUS,HALF_HEIGHT (cylinder).")
@click.option("--threads", type=int, default=None,
              help="Numba threads stepping the traffic, at most the CPU cores (same results; used from 4,000 "
                   "aircraft on, where they help on idle cores). Default: AAMSIM_THREADS, else 1.")
@click.option("--max-aircraft", type=click.IntRange(min=1), default=DEFAULT_LOCAL_MAX_AIRCRAFT, show_default=True,
              help="Most aircraft flying at once; a CRE past it, or an MCRE that does not fit whole, is a "
                   "reported error and the run goes on.")
@click.option("--overlay", "overlays", multiple=True, metavar="FILE|opensky:LAT0,LON0,LAT1,LON1",
              help="Real traffic as non-cooperative intruders: a recording (OpenSky, traffic library; "
                   "docs/real-traffic.md) or live OpenSky state vectors in a box (paced to real time). Repeatable.")
@click.option("--overlay-offset", default="", metavar="[-][[HH:]MM:]SS|@UTC",
              help="Scenario time of the recordings' first report (default 0), or @UTC-TIME: the recording's "
                   "moment played at time 0.")
@click.option("--overlay-area", default="", metavar="LAT0,LON0,LAT1,LON1",
              help="Replay only the recordings' reports inside this box [deg].")
@click.option("--view", "show_view", is_flag=True,
              help="Show the simulation live in the web viewer (docs/viewer.md); it stays up after the run "
                   "until Ctrl-C.")
@_viewer_options
@click.option("--pace", type=click.FloatRange(min=0, min_open=True), default=None,
              help="With --view: run at most this many times faster than real time (e.g. 10), to watch it.")
@click.option("--allow-commands", is_flag=True,
              help="With --view: let the browser send stack commands to the simulation.")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="A setting, as aamsim batch takes it (keys: dt, until, nmac, lowc, log_period, "
                   "delete_on_arrival, stack); it replaces the option of the same name. stack=COMMAND runs a stack "
                   "command at time 0 before the scenario, e.g. --set \"stack=RESO DAA\" (repeatable).")
def run(scenario: str, until: str | None, out_dir: Path | None, dt: float, seed: int | None, strict: bool,
        quiet: bool, log_period: float, plugins: tuple[str, ...], delete_on_arrival: bool, metrics: str,
        nmac: str, lowc: str, threads: int | None, max_aircraft: int, overlays: tuple[str, ...],
        overlay_offset: str, overlay_area: str, show_view: bool, host: str, port: int, allow_hosts: tuple[str, ...],
        open_browser: bool, pace: float | None, allow_commands: bool, sets: tuple[str, ...]) -> None:
    """Simulate SCENARIO headless, as fast as possible, and write a run directory.

    SCENARIO is a path, or the name of a scenario shipped with aamsim
    (e.g. scn/nyc_day.scn). With --view, watch it in the web viewer.
    --set "stack=RESO DAA" switches a service on for this run only: the
    scenario file (and its hash, which aamsim compare pairs runs by) is unchanged.
    """
    if not show_view and (pace is not None or allow_commands or open_browser):
        raise click.UsageError("--pace, --allow-commands and --open go with --view")
    from aamsim.clock import TimeStepError, validate_dt
    from aamsim.runner import OverlayError, RunConfig, ScenarioNotFound, StrictValidationFailed, run_scenario
    from aamsim.scenarios import resolve_scenario

    try:
        dt = validate_dt(dt)
    except TimeStepError as exc:
        raise click.BadParameter(str(exc), param_hint="--dt") from None
    if log_period < 0:
        raise click.BadParameter("--log-period cannot be negative")
    from aamsim.threads import check_threads

    try:
        threads = check_threads(threads)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--threads") from None
    until_s = _time_option(until)
    groups = tuple(g.strip() for g in metrics.split(",") if g.strip())
    from aamsim.metrics.registry import MetricRegistry
    from aamsim.metrics.standard import register_standard_metrics

    known = MetricRegistry()
    register_standard_metrics(known)
    unknown = [g for g in groups if g not in known.groups]
    if unknown:
        raise click.BadParameter(f"unknown metric group(s) {', '.join(unknown)}; known: "
                                 f"{', '.join(sorted(known.groups))}", param_hint="--metrics")
    volumes = (_volume("nmac", nmac), _volume("lowc", lowc))
    try:
        area = tuple(float(x) for x in overlay_area.split(",") if x.strip())
    except ValueError:
        raise click.BadParameter(f'"{overlay_area}": expected LAT0,LON0,LAT1,LON1 in degrees',
                                 param_hint="--overlay-area") from None
    if area and len(area) != 4:
        raise click.BadParameter(f'"{overlay_area}": expected 4 numbers LAT0,LON0,LAT1,LON1',
                                 param_hint="--overlay-area")
    cfg = RunConfig(scenario, out_dir, until_s, dt, seed, strict, log_period, plugins, delete_on_arrival, groups,
                    volumes, threads, overlays=overlays, overlay_offset=overlay_offset, overlay_area=area,
                    max_aircraft=max_aircraft)
    if sets:
        cfg = _with_settings(cfg, sets)

    def listener(msg: Any) -> None:
        if msg.kind in ("error", "warning") or not quiet and msg.kind in ("echo", "note"):
            click.echo(str(msg), err=True)

    path = resolve_scenario(scenario)
    live = None
    if show_view:
        from aamsim.viewer.live import LiveViewer

        live = LiveViewer(host, port, allow_commands=allow_commands, title=Path(scenario).stem,
                          allow_hosts=allow_hosts)
        try:
            live.start()
            assert live.page_url is not None
            _announce_viewer(live.page_url, host, open_browser)
        except OSError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)

    simulated: list[Any] = []

    def setup(sim: Any, text: str) -> None:
        if live is not None:
            live.attach(sim, text, pace=pace)
            simulated.append(sim)

    total = until_s
    progress = _Progress(total, quiet)
    try:
        result = run_scenario(cfg, progress=progress, listener=listener, setup=setup)
    except (ScenarioNotFound, OverlayError) as exc:
        progress.close()
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except CommandError as exc:  # e.g. --plugin names no plugin
        progress.close()
        click.echo(f"error: {exc.message}", err=True)
        sys.exit(2)
    except StrictValidationFailed as exc:
        progress.close()
        for err in exc.errors:
            click.echo(str(err), err=True)
        click.echo(f"{path}: {len(exc.errors)} error(s); nothing simulated (--strict)", err=True)
        sys.exit(2)
    except OSError as exc:  # a full disk while the run directory is written: a message, not a traceback
        progress.close()
        where = f" {exc.filename}" if exc.filename else ""
        click.echo(f"error: cannot write the run directory{where}: {exc.strerror or exc}", err=True)
        sys.exit(1)
    except Exception:
        progress.close()
        raise
    progress.close()
    s = result.summary
    if result.sim.run_outputs.write_failures:
        click.echo(f"error: the run stopped at sim time {s['sim_time_s']:.1f} s: an output file could not be "
                   f"written (see above); {result.out_dir} holds the run up to there", err=True)
        sys.exit(1)
    if s.get("interrupted"):
        click.echo(f"{s['interrupted_by']}: stopped at sim time {s['sim_time_s']:.1f} s; the run directory "
                   f"{result.out_dir} is complete up to there", err=True)
        sys.exit(130 if s["interrupted_by"] == "SIGINT" else 143)
    if not quiet:
        click.echo(
            f"{s['scenario']}: {s['flights_created']} flights created, {s['flights_arrived']} arrived, "
            f"{s['aircraft_at_end']} still flying\n"
            f"sim time {s['sim_time_s']:.1f} s in {s['wall_time_s']:.2f} s wall "
            f"(speed-up {s['speedup'] or 0:.0f}x, {s['aircraft_steps_per_s'] or 0:,.0f} aircraft-steps/s)\n"
            f"errors: {s['errors']}; results in {result.out_dir}"
        )
        if "safety" in s:
            sf = s["safety"]
            sep = sf["min_separation_m"]
            click.echo(f"safety: {sf['nmac_events']} NMAC, {sf['lowc_events']} LoWC events, "
                       f"min separation {'-' if sep is None else f'{sep:.1f}'} m")
            if s.get("real_traffic"):
                replayed = sum(int(r["aircraft_replayed"]) for r in s["real_traffic"])
                click.echo(f"real traffic: {replayed} aircraft replayed; AAM vs AAM: "
                           f"{sf['nmac_events_aam_vs_aam']} NMAC, {sf['lowc_events_aam_vs_aam']} LoWC; "
                           f"AAM vs real traffic: {sf['nmac_events_aam_vs_real_traffic']} NMAC, "
                           f"{sf['lowc_events_aam_vs_real_traffic']} LoWC")
    if live is not None:
        live.finish(simulated[0] if simulated else None)
        click.echo(f"run finished; the viewer shows its last picture at {live.url} until Ctrl-C", err=True)
        from aamsim.viewer.server import interrupted_by_signals

        try:
            with interrupted_by_signals():
                while True:
                    time.sleep(3600)
        except KeyboardInterrupt:
            live.close()


def _with_settings(cfg: Any, sets: tuple[str, ...]) -> Any:
    """``cfg`` with ``aamsim run --set KEY=VALUE ...`` applied (aamsim batch's keys and parsers).

    A key given here replaces the option of the same name (``--set lowc=600`` replaces ``--lowc``
    and leaves ``--nmac`` as given). Each key once, except ``stack``: its commands run in the order
    given. A key given twice is a sweep, which is what ``aamsim batch`` is for.
    """
    from aamsim.batch.plan import BatchError, parse_settings

    stack = [item for item in sets if item.partition("=")[0].strip().lower() == "stack"]
    others = [item for item in sets if item not in stack]
    try:
        points = parse_settings(others)
        commands = [parse_settings([item])[0].run_config_fields()["commands"][0] for item in stack]
    except BatchError as exc:
        raise click.BadParameter(str(exc), param_hint="--set") from None
    if len(points) > 1:
        raise click.BadParameter("a key given twice is a sweep: aamsim batch runs those", param_hint="--set")
    fields = points[0].run_config_fields()
    if "volumes" in fields:  # the batch parser fills the volume not given with its default: keep the option's
        given = {key for key, _ in points[0].values}
        fields["volumes"] = tuple(new if name in given else old
                                  for name, new, old in zip(("nmac", "lowc"), fields["volumes"], cfg.volumes))
    if commands:
        fields["commands"] = tuple(commands)
    return replace(cfg, **fields)


def _write_video(run_dir: Path, video_path: Path, t_from: str | None, t_to: str | None, speed: float, fps: float,
                 size: str) -> None:
    """``aamsim video`` and ``aamsim view --video``: a run replayed into an MP4 or GIF (exit 2 with a message)."""
    from aamsim.render.video import write_run_video
    from aamsim.viewer.frames import ReplayError

    try:
        width, height = (int(x) for x in size.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"{size!r}: expected WIDTHxHEIGHT, e.g. 800x800", param_hint="--size") from None
    try:
        n = write_run_video(run_dir, video_path, t_from=_time_option(t_from), t_to=_time_option(t_to),
                            speed=speed, fps=fps, width=width, height=height)
    except (ReplayError, ValueError) as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    click.echo(f"{video_path}: {n} frames, {n / fps:.1f} s at {fps:g} frames/s ({speed:g}x)")


@main.command()
@click.argument("run_dir", type=click.Path(path_type=Path))
@click.option("-o", "--output", "video_path", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="MP4 or GIF to write (chosen by the suffix).")
@click.option("--from", "t_from", default=None, help="First sim time (seconds or HH:MM:SS).")
@click.option("--to", "t_to", default=None, help="Last sim time (seconds or HH:MM:SS).")
@click.option("--speed", type=float, default=60.0, show_default=True, help="Sim seconds per second of video.")
@click.option("--fps", type=float, default=10.0, show_default=True, help="Frames per second.")
@click.option("--size", default="800x800", show_default=True, help="WIDTHxHEIGHT in pixels.")
def video(run_dir: Path, video_path: Path, t_from: str | None, t_to: str | None, speed: float, fps: float,
          size: str) -> None:
    """Replay RUN_DIR (an aamsim run directory) into a video; the same as ``aamsim view RUN_DIR --video``.

    Frame k shows sim time FROM + k * SPEED / FPS: the aircraft coloured by
    state (normal, in LoWC, in NMAC, holding) with short trails, and rings
    where NMAC/LoWC events begin.
    """
    _write_video(run_dir, video_path, t_from, t_to, speed, fps, size)


@main.command()
@click.argument("run_dir", type=click.Path(path_type=Path))
@_viewer_options
@click.option("--video", "video_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the replay to this MP4 or GIF instead of serving it.")
@click.option("--from", "t_from", default=None, help="With --video: first sim time (seconds or HH:MM:SS).")
@click.option("--to", "t_to", default=None, help="With --video: last sim time (seconds or HH:MM:SS).")
@click.option("--speed", type=float, default=60.0, show_default=True,
              help="With --video: sim seconds per second of video.")
@click.option("--fps", type=float, default=10.0, show_default=True, help="With --video: frames per second.")
@click.option("--size", default="800x800", show_default=True, help="With --video: WIDTHxHEIGHT in pixels.")
def view(run_dir: Path, host: str, port: int, allow_hosts: tuple[str, ...], open_browser: bool,
         video_path: Path | None, t_from: str | None, t_to: str | None, speed: float, fps: float, size: str) -> None:
    """Replay RUN_DIR (an aamsim run directory) in the web viewer until Ctrl-C, or into a video.

    The page shows the traffic over the scenario's network with a time slider,
    playback speed, zoom/pan, follow and filters (docs/viewer.md).
    """
    from aamsim.viewer.frames import ReplayError
    from aamsim.viewer.server import serve_replay

    _warn_if_incomplete(run_dir)
    if video_path is not None:
        _write_video(run_dir, video_path, t_from, t_to, speed, fps, size)
        return
    if t_from is not None or t_to is not None:
        raise click.UsageError("--from and --to go with --video")
    try:
        serve_replay(str(run_dir), host, port, lambda url: _announce_viewer(url, host, open_browser), allow_hosts,
                     on_warning=lambda text: click.echo(f"warning: {text}", err=True))
    except ReplayError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except OSError as exc:
        click.echo(f"error: cannot serve on {host}:{port}: {exc}", err=True)
        sys.exit(2)


def _warn_if_incomplete(run_dir: Path) -> None:
    """A warning when RUN_DIR's summary.json is a provisional one: its run was killed (or still runs)."""
    import json

    from aamsim.output.summary_file import IncompleteSummary, check_complete

    try:
        summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return  # no summary, or a broken one: the replay reports what it needs
    if not isinstance(summary, dict):
        return
    try:
        check_complete(summary, str(run_dir))
    except IncompleteSummary as exc:
        click.echo(f"warning: {exc}; showing what it wrote", err=True)


def figure_options(fn: Any) -> Any:
    """The options of ``aamsim figure`` (shared with its alias ``uam2scn figure``)."""
    for opt in reversed((
        click.option("-o", "--output", "out_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
                     help="PNG to write (default RUN_DIR/traffic.png)."),
        click.option("--snapshot", default="auto", show_default=True,
                     help="Show aircraft in flight at this sim time (s or HH:MM:SS) as arrows; 'auto': the busiest "
                          "moment; 'none': no arrows."),
        click.option("--every", type=click.IntRange(min=1), default=1, show_default=True,
                     help="Keep every N-th trajectory sample (lighter drawings of long runs)."),
        click.option("--title", default=None, help="Figure title."),
        click.option("--no-labels", is_flag=True, help="Do not label the vertiports."),
    )):
        fn = opt(fn)
    return fn


def draw_figure(run_dir: Path, out_path: Path | None, snapshot: str, every: int, title: str | None,
                no_labels: bool, layout: Any = None) -> None:
    """Draw a run's traffic map (``aamsim figure``); exits 2 with a message naming a bad file or option."""
    from aamsim.render.figure import busiest_time, plot_run
    from aamsim.viewer.frames import ReplayError, RunReplay

    try:
        if snapshot.lower() == "none":
            snap = None
        elif snapshot.lower() == "auto":
            snap = busiest_time(RunReplay(run_dir))
        else:
            try:
                snap = parse_time(snapshot)
            except UnitParseError:
                raise click.BadParameter(f"--snapshot {snapshot!r}: seconds, HH:MM:SS, auto or none") from None
        out, n = plot_run(run_dir, out_path or run_dir / "traffic.png", title=title, snapshot_s=snap,
                          labels=not no_labels, layout=layout, every=every)
    except ReplayError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    click.echo(f"{out}: {n} trajectories")


@main.command()
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@figure_options
def figure(run_dir: Path, out_path: Path | None, snapshot: str, every: int, title: str | None,
           no_labels: bool) -> None:
    """Draw the network, the trajectories flown and the conflicts of an aamsim RUN_DIR (PNG)."""
    draw_figure(run_dir, out_path, snapshot, every, title, no_labels)


@main.command()
@click.argument("runs", nargs=-1, required=True, type=click.Path(exists=True))
@click.option("--baseline", "baselines", multiple=True, type=click.Path(exists=True),
              help="Baseline run directory (repeatable); default: the last RUNS argument.")
@click.option("--out", "out_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the comparison as JSON here (default: comparison.json in the first run directory).")
def compare(runs: tuple[str, ...], baselines: tuple[str, ...], out_path: Path | None) -> None:
    """Risk ratio and LoWC ratio of RUN(s) against the unequipped BASELINE run(s), beside their cost.

    aamsim compare RUN_DIR BASELINE_RUN_DIR compares two runs; folders of runs
    (e.g. 100 evaluation episodes) are paired by seed and reported as mean +- std.
    Each side's flights completed, unfinished and not departed, airborne holding,
    mean delay and advisories are printed beside the ratios; a warning says when the
    two sides did not complete the same number of flights.
    """
    import json

    from aamsim.metrics.compare import ComparisonError, compare_runs, expand_runs, format_operational, format_ratio

    run_args = list(runs)
    base_args = list(baselines)
    if not base_args:
        if len(run_args) < 2:
            raise click.UsageError("give RUN_DIR BASELINE_RUN_DIR, or --baseline")
        base_args = [run_args.pop()]
    try:
        comparison = compare_runs(expand_runs(run_args), expand_runs(base_args))
    except ComparisonError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    click.echo(f"scenario {comparison.scenario}, {comparison.runs} run(s) paired by seed")
    click.echo(f"risk ratio (NMAC): {format_ratio(comparison.risk_ratio)}")
    click.echo(f"LoWC ratio:        {format_ratio(comparison.lowc_ratio)}")
    for line in format_operational(comparison):
        click.echo(line)
    for warning in comparison.warnings:
        click.echo(f"warning: {warning}", err=True)
    target = out_path or (Path(run_args[0]) / "comparison.json")
    target.write_text(json.dumps(comparison.to_dict(), indent=2) + "\n")
    click.echo(f"written to {target}")


@main.command()
@click.argument("scenarios", nargs=-1, required=True)
@click.option("--seeds", type=click.IntRange(min=1), default=1, show_default=True,
              help="Seeds per scenario and setting: SEED-START .. SEED-START+N-1.")
@click.option("--seed-start", type=int, default=0, show_default=True, help="First seed.")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="A setting of every run; a key given several times is a sweep axis (cartesian product). "
                   "Keys: dt, until, nmac, lowc, log_period, delete_on_arrival, stack.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Batch folder (default runs/batch-<timestamp>/).")
@click.option("--address", default=None,
              help="Ray cluster to run on (auto, HOST:PORT or ray://HOST:10001); default: a local Ray.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="CPUs of the local Ray (default: all of this machine's).")
@click.option("--no-ray", is_flag=True, help="Run the jobs one by one in this process instead of on Ray.")
@click.option("--quiet", is_flag=True, help="No progress bar and no summary.")
def batch(scenarios: tuple[str, ...], seeds: int, seed_start: int, sets: tuple[str, ...], out_dir: Path | None,
          address: str | None, workers: int | None, no_ray: bool, quiet: bool) -> None:
    """Run SCENARIOS x settings x seeds in parallel on Ray; one run directory each and an aggregate table.

    A SCENARIO is a path or a shipped scenario name; a BlueSky batch file (SCEN blocks) counts as one
    scenario per block. Runs write no trajectories.csv unless --set log_period=SECONDS is given.
    The batch folder gets runs.csv (a row per run), aggregate.csv and aggregate.md (mean, std and
    95 % confidence interval over seeds of every safety and operational metric).
    """
    from datetime import datetime

    from aamsim.batch import BatchError, load_sources, parse_settings, plan_jobs, run_batch
    from aamsim.scenarios import resolve_scenario

    if not no_ray:
        require("batch", "aamsim batch", ("ray",), hint="or --no-ray: the runs one by one in this process")

    paths, missing = [], []
    for name in scenarios:
        found = resolve_scenario(name)
        (paths.append(found.resolve()) if found is not None else missing.append(name))
    if missing:
        click.echo(f"error: scenario(s) not found: {', '.join(missing)}", err=True)
        sys.exit(2)
    try:
        sources, warnings = load_sources(paths)
        settings = parse_settings(sets)
    except BatchError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    for warning in warnings:
        click.echo(f"warning: {warning}", err=True)
    jobs = plan_jobs(sources, settings, range(seed_start, seed_start + seeds), base={"log_period_s": 0.0})
    out = out_dir or Path("runs") / f"batch-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
    bar = None
    if not quiet:
        from tqdm import tqdm

        click.echo(f"{len(jobs)} runs: {len(sources)} scenario(s) x {len(settings)} setting(s) x {seeds} seed(s)",
                   err=True)
        bar = tqdm(total=len(jobs), unit="run", file=sys.stderr, dynamic_ncols=True)

    def started(info: dict[str, Any]) -> None:
        if not quiet:
            click.echo(f"Ray: {info['nodes']} node(s), {info['cpus']} CPU(s)", err=True)

    def finished(result: Any) -> None:
        if result.error is not None:
            click.echo(f"error: {jobs[result.index].relpath}: {result.error}", err=True)
        if bar is not None:
            bar.update(1)

    result = run_batch(jobs, out, use_ray=not no_ray, address=address, workers=workers, on_result=finished,
                       on_started=started)
    if bar is not None:
        bar.close()
    if not quiet:
        click.echo(f"{len(result.rows) - result.failed} of {len(result.rows)} runs done; "
                   f"tables in {out / 'aggregate.md'} and {out / 'aggregate.csv'}")
    sys.exit(1 if result.failed else 0)


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


@main.command()
@click.option("--bind", default="tcp://127.0.0.1:5555", show_default=True,
              help="ZeroMQ endpoint to listen on (loopback by default; tcp://*:PORT for every interface).")
@click.option("--plugin", "plugins", multiple=True, help="Load a plugin into every session's simulation (repeatable).")
@click.option("--max-message-bytes", type=click.IntRange(min=1024), default=16 * 1024 * 1024, show_default=True,
              help="Largest request accepted; larger ones get an error reply.")
@click.option("--session-timeout", type=click.FloatRange(min=0, min_open=True), default=300.0, show_default=True,
              help="Free the simulation of a client silent for this long [s].")
@click.option("--max-sessions", type=click.IntRange(min=1), default=64, show_default=True,
              help="Most simulations served at once.")
@click.option("--scenario-root", "scenario_roots", multiple=True,
              type=click.Path(exists=True, file_okay=False, path_type=Path),
              help="Folder clients may load scenarios from (repeatable; default: the working directory). "
                   "Shipped scenarios are always allowed.")
@click.option("--allow-shutdown", is_flag=True, help="Let a client stop the server with a shutdown request.")
@click.option("--allow-live-overlays", is_flag=True,
              help="Let clients start live OpenSky overlays (REPLAY OPENSKY, overlay=opensky:...): the server "
                   "then polls the network for them.")
@click.option("--max-aircraft", type=click.IntRange(min=1), default=DEFAULT_MAX_AIRCRAFT, show_default=True,
              help="Most aircraft one session may fly at once; creating more is refused.")
@click.option("--log-level", type=click.Choice(["DEBUG", "INFO", "WARNING", "ERROR"], case_sensitive=False),
              default="INFO", show_default=True)
@click.option("--view", "show_view", is_flag=True,
              help="Show the traffic of the session that stepped last in the web viewer (read-only).")
@_viewer_options
def serve(bind: str, plugins: tuple[str, ...], max_message_bytes: int, session_timeout: float, max_sessions: int,
          scenario_roots: tuple[Path, ...], allow_shutdown: bool, allow_live_overlays: bool, max_aircraft: int,
          log_level: str, show_view: bool, host: str, port: int, allow_hosts: tuple[str, ...],
          open_browser: bool) -> None:
    """Run a headless simulation server for RL environments (ZeroMQ, docs/protocol.md).

    Each client gets its own simulation. Ctrl-C or SIGTERM stops the server.
    With --view, a web viewer shows the session that stepped last.
    """
    if open_browser and not show_view:
        raise click.UsageError("--open goes with --view")
    import logging

    from aamsim.errors import CommandError
    from aamsim.plugins import plugin_module

    logging.basicConfig(level=log_level.upper(), format="%(asctime)s %(name)s %(levelname)s: %(message)s")
    try:
        for name in plugins:
            plugin_module(name)
        bridge = plugin_module("BRIDGE")
    except CommandError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)

    def ready(endpoint: str) -> None:
        click.echo(f"aamsim serve: listening on {endpoint}", err=False)
        sys.stdout.flush()

    import zmq

    live = None
    if show_view:
        from aamsim.viewer.live import LiveViewer

        live = LiveViewer(host, port, title="aamsim serve: waiting for a session", allow_hosts=allow_hosts)
        try:
            _announce_viewer(live.start(), host, open_browser)
        except OSError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)
    try:
        code = bridge.serve(bind, tuple(plugins), on_ready=ready, max_message_bytes=max_message_bytes,
                            session_timeout_s=session_timeout, max_sessions=max_sessions,
                            scenario_roots=scenario_roots, allow_shutdown=allow_shutdown,
                            allow_live_overlays=allow_live_overlays, max_aircraft=max_aircraft,
                            on_traffic=live.show_episode if live is not None else None)
    except zmq.ZMQError as exc:
        click.echo(f"error: cannot listen on {bind}: {exc}", err=True)
        sys.exit(2)
    finally:
        if live is not None:
            live.close()
    sys.exit(code)
