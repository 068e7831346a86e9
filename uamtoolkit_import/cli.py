"""The ``uam2scn`` command line.

``uam2scn SCHEDULE.csv --network NETWORK.json -o OUT.scn`` converts a
schedule (the default action); the sub-commands generate schedules
(``synth``), draw traffic maps (``figure``), regenerate the shipped
scenarios (``scenarios``) and export the network (``network``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import click

from aamsim.cli import draw_figure, figure_options
from uamtoolkit_import.fields import aircraft_type_problem
from uamtoolkit_import.netfile import NetworkError, load_network, nyc_network
from uamtoolkit_import.network import Network
from uamtoolkit_import.times import TimeParseError, format_clock, parse_clock


class DefaultCommandGroup(click.Group):
    """A group that runs ``default_command`` when the first argument names no sub-command."""

    default_command = "convert"

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands and args[0] not in ("--help", "-h", "--version"):
            args = [self.default_command, *args]
        return super().parse_args(ctx, args)


def _network(path: Path | None) -> Network:
    try:
        return nyc_network() if path is None else load_network(path)
    except NetworkError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)


def _clock(_ctx: click.Context, _param: click.Parameter, value: str | None) -> float | None:
    if value is None:
        return None
    try:
        return parse_clock(value)
    except TimeParseError as exc:
        raise click.BadParameter(str(exc)) from None


_NETWORK_OPTION = click.option(
    "--network",
    "network_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    help="Network file (JSON or GeoJSON). Default: the shipped New York network.",
)


@click.group(cls=DefaultCommandGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="aamsim")
def main() -> None:
    """uam2scn: UAMToolkit flight schedules -> BlueSky/aamsim scenarios.

    \b
    uam2scn SCHEDULE.csv --network NETWORK.json -o OUT.scn [options]   convert (default)
    uam2scn synth -o SCHEDULE.csv                                      synthetic UAMToolkit schedule
    uam2scn figure RUN_DIR -o traffic.png                              traffic map of an aamsim run
    uam2scn scenarios                                                  regenerate aamsim/scn/nyc_*.scn
    """


@main.command("convert")
@click.argument("schedule_path", metavar="SCHEDULE.csv", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@_NETWORK_OPTION
@click.option(
    "-o",
    "--output",
    "out_path",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="Scenario file to write.",
)
@click.option("--start", callback=_clock, help="Keep flights departing at or after HH:MM[:SS]; it becomes 00:00:00.")
@click.option("--end", callback=_clock, help="Keep flights departing before HH:MM[:SS].")
@click.option(
    "--alt-noise-ft",
    type=click.FloatRange(min=0.0),
    default=100.0,
    show_default=True,
    help="Uniform altitude noise half-width [ft].",
)
@click.option(
    "--type",
    "actype",
    default="EC35",
    show_default=True,
    help="BlueSky aircraft type of every flight (SCHEDULE: the schedule's type column).",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the altitude noise.")
@click.option("--strict", is_flag=True, help="Fail (exit 2) listing every bad row instead of skipping them.")
def convert_command(
    schedule_path: Path,
    network_path: Path | None,
    out_path: Path,
    start: float | None,
    end: float | None,
    alt_noise_ft: float,
    actype: str,
    seed: int,
    strict: bool,
) -> None:
    """Convert SCHEDULE.csv into a scenario file (the default command)."""
    from uamtoolkit_import.convert import ConvertOptions, write_scenario
    from uamtoolkit_import.headers import ScheduleFormatError
    from uamtoolkit_import.schedule import read_schedule

    if start is not None and end is not None and end <= start:
        raise click.BadParameter(f"--end {format_clock(end)} is not after --start {format_clock(start)}")
    if actype.upper() != "SCHEDULE" and (problem := aircraft_type_problem(actype)):
        raise click.BadParameter(f"--type: {problem}")
    network = _network(network_path)
    try:
        schedule = read_schedule(schedule_path, network)
    except ScheduleFormatError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    for warning in schedule.warnings:
        click.echo(f"warning: {warning}", err=True)
    for err in schedule.errors:
        click.echo(str(err), err=True)
    if strict and schedule.errors:
        click.echo(
            f"{schedule_path}: {len(schedule.errors)} error(s) in {schedule.skipped_rows} row(s); "
            "nothing written (--strict)",
            err=True,
        )
        sys.exit(2)
    options = ConvertOptions(
        start_s=start or 0.0, end_s=end, alt_noise_ft=alt_noise_ft, aircraft_type=actype, seed=seed
    )
    out_path.parent.mkdir(parents=True, exist_ok=True)
    with open(out_path, "w", encoding="utf-8", newline="\n") as fh:
        result = write_scenario(schedule, network, fh, options)
    window = f", {result.outside_window} outside the time window" if start is not None or end is not None else ""
    click.echo(f"{out_path}: {len(result.written)} flights written, {schedule.skipped_rows} skipped{window}")


@main.command("synth")
@_NETWORK_OPTION
@click.option(
    "-o",
    "--output",
    "out_path",
    type=click.Path(dir_okay=False, allow_dash=True),
    default="-",
    show_default=True,
    help="Schedule CSV to write ('-': standard output).",
)
@click.option("--fleet", type=click.IntRange(min=1), default=100, show_default=True, help="Number of aircraft.")
@click.option("--seed", type=int, default=2022, show_default=True, help="Random seed.")
@click.option(
    "--daily-requests",
    type=click.FloatRange(min=0.0),
    default=6000.0,
    show_default=True,
    help="Expected trip requests per day (demand scale).",
)
@click.option(
    "--turnaround-min",
    type=click.FloatRange(min=0.0),
    default=10.0,
    show_default=True,
    help="Ground time between two flights of an aircraft [min].",
)
@click.option(
    "--max-wait-min",
    type=click.FloatRange(min=0.0),
    default=15.0,
    show_default=True,
    help="A request waits at most this long for an aircraft [min].",
)
@click.option(
    "--hours",
    type=click.FloatRange(min=0.0, max=24.0, min_open=True),
    default=24.0,
    show_default=True,
    help="Generate flights departing in the first HOURS of the day.",
)
@click.option("--type", "actype", default="EVTOL4", show_default=True, help="Aircraft type written in the schedule.")
@click.option(
    "--prefix",
    default="UAM",
    show_default=True,
    help="Flight ids are PREFIXnnnn in departure order (another prefix keeps two days' callsigns apart).",
)
def synth_command(
    network_path: Path | None,
    out_path: str,
    fleet: int,
    seed: int,
    daily_requests: float,
    turnaround_min: float,
    max_wait_min: float,
    hours: float,
    actype: str,
    prefix: str,
) -> None:
    """Generate a synthetic UAMToolkit schedule (a day of fleet operations)."""
    from dataclasses import replace

    from uamtoolkit_import.demand import DemandModel
    from uamtoolkit_import.schedule import write_schedule
    from uamtoolkit_import.synth import SynthConfig, synthesize

    if problem := aircraft_type_problem(actype):
        raise click.BadParameter(f"--type: {problem}")
    network = _network(network_path)
    config = SynthConfig(
        fleet_size=fleet,
        seed=seed,
        demand=replace(DemandModel(), daily_requests=daily_requests),
        turnaround_s=60.0 * turnaround_min,
        max_wait_s=60.0 * max_wait_min,
        day_s=3600.0 * hours,
        aircraft_type=actype,
        flight_prefix=prefix,
    )
    result = synthesize(network, config)
    with click.open_file(out_path, "w", encoding="utf-8") as fh:
        write_schedule(result.flights, fh)
    click.echo(
        f"{out_path}: {result.served} flights from {result.requests} requests "
        f"({result.lost} lost), fleet {fleet}, seed {seed}",
        err=True,
    )


@main.command("figure")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@figure_options
@_NETWORK_OPTION
def figure_command(
    run_dir: Path,
    out_path: Path | None,
    snapshot: str,
    every: int,
    title: str | None,
    no_labels: bool,
    network_path: Path | None,
) -> None:
    """Draw the network and the trajectories flown in an aamsim RUN_DIR (PNG); alias of ``aamsim figure``.

    The map is the UAMToolkit network (--network, default the shipped New York one).
    """
    from uamtoolkit_import.figures import network_layout

    draw_figure(run_dir, out_path, snapshot, every, title, no_labels, layout=network_layout(_network(network_path)))


@main.command("scenarios")
@click.option(
    "--out-dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Where to write them (default: aamsim/scn of the aamsim package in use).",
)
@click.option(
    "--schedule-out",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Also write the day's schedule CSV here.",
)
def scenarios_command(out_dir: Path | None, schedule_out: Path | None) -> None:
    """Regenerate the shipped scenarios nyc_day, nyc_train_100 and nyc_eval_678 (deterministic)."""
    from uamtoolkit_import.scenarios import default_output_dir, regenerate

    for path, n, start in regenerate(out_dir or default_output_dir(), schedule_out):
        click.echo(f"{path}: {n} flights (window from {format_clock(start)})")


@main.command("network")
@_NETWORK_OPTION
@click.option(
    "--geojson",
    "geojson_out",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Write the network as GeoJSON here.",
)
def network_command(network_path: Path | None, geojson_out: Path | None) -> None:
    """Summarise a network (default: New York), or export it as GeoJSON."""
    from uamtoolkit_import.netfile import to_geojson

    network = _network(network_path)
    lanes = sorted({lane for s in network.segments for lane in s.lanes_ft})
    click.echo(
        f"{network.name}: {len(network.vertiports)} vertiports, {len(network.nodes)} route nodes, "
        f"{len(network.segments)} segments, lanes {', '.join(f'{x:g}' for x in lanes)} ft"
    )
    if geojson_out is not None:
        data: dict[str, Any] = to_geojson(network)
        geojson_out.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
        click.echo(f"{geojson_out}: written")
