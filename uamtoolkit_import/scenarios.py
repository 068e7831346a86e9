"""The scenarios shipped in ``aamsim/scn/`` and how they are regenerated.

They come from two synthetic days (:func:`uamtoolkit_import.synth.synthesize`
on the New York network), each written as a schedule in the contract format
and converted by :func:`convert.convert`:

* the *training day* (the default configuration, seed 2022):

  * ``nyc_day.scn``: the whole day from midnight;
  * ``nyc_train_100.scn``: the 25-minute window holding exactly 100 departures
    whose start is nearest 08:00 (the morning peak), on a whole minute when
    possible (the paper's training scenario);

* the *evaluation day* (:data:`EVAL_DRAW`: another demand draw, seed 2023 with
  6,600 trip requests a day, flight ids ``EVLnnnn``):

  * ``nyc_eval_678.scn``: the 5-hour window holding exactly 678 departures
    whose start is nearest 04:00 among the windows that do not overlap
    ``nyc_train_100``'s window of the day (from the night into the morning;
    the paper's evaluation scenario, "not used during training": it shares
    no flight, callsign or time of day with the training scenario).

The evaluation day draws more requests than the training day because, with the
training day's demand, no 5-hour window clear of 09:10-09:35 holds 678
departures (the night is too quiet, the rest of the day too busy).

``uam2scn scenarios`` rewrites them; the output is identical on every run.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from uamtoolkit_import.convert import ConvertOptions, convert
from uamtoolkit_import.demand import DemandModel
from uamtoolkit_import.netfile import nyc_network
from uamtoolkit_import.network import Network
from uamtoolkit_import.schedule import parse_schedule, write_schedule
from uamtoolkit_import.synth import SynthConfig, synthesize
from uamtoolkit_import.times import format_clock

ALT_NOISE_FT = 100.0
NOISE_SEED = 2022
AIRCRAFT_TYPE = "EC35"


DAY_DRAW = SynthConfig()
"""The training day: the generator's defaults (seed 2022, fleet 100, 6,000 trip requests a day)."""
EVAL_DRAW = SynthConfig(seed=2023, demand=replace(DemandModel(), daily_requests=6600.0), flight_prefix="EVL")
"""The evaluation day: another seed, more demand (see the module docstring), its own flight ids."""


@dataclass(frozen=True)
class ShippedScenario:
    """A shipped scenario: a window of a synthetic day.

    Attributes:
        filename: name in ``aamsim/scn/``.
        title: first comment line.
        length_s: window length [s] (None: the whole day from midnight).
        flights: exact number of departures the window must hold.
        anchor_s: the window start is chosen nearest this time of day [s].
        draw: the synthetic day it is cut from.
        disjoint_from: a shipped scenario (listed before it) whose window of the day it must not overlap.
    """

    filename: str
    title: str
    length_s: float | None = None
    flights: int | None = None
    anchor_s: float = 0.0
    draw: SynthConfig = DAY_DRAW
    disjoint_from: str | None = None


SHIPPED: tuple[ShippedScenario, ...] = (
    ShippedScenario("nyc_day.scn", "New York AAM traffic, a full day from midnight, 100-aircraft fleet"),
    ShippedScenario(
        "nyc_train_100.scn",
        "New York AAM traffic: 100 flights in 25 minutes (training scenario)",
        25 * 60.0,
        100,
        8 * 3600.0,
    ),
    ShippedScenario(
        "nyc_eval_678.scn",
        "New York AAM traffic: 678 flights in 5 hours (evaluation scenario)",
        5 * 3600.0,
        678,
        4 * 3600.0,
        draw=EVAL_DRAW,
        disjoint_from="nyc_train_100.scn",
    ),
)


class WindowNotFound(ValueError):
    """No window of the asked length holds exactly the asked number of departures."""


def find_window(
    departures_s: np.ndarray,
    length_s: float,
    count: int,
    anchor_s: float,
    day_s: float,
    avoid: tuple[tuple[float, float], ...] = (),
) -> float:
    """Start [s] of a window ``[start, start + length_s)`` holding exactly ``count`` departures.

    Candidate starts are whole seconds in ``[0, day_s - length_s]`` whose window does not
    overlap any ``[lo, hi)`` of ``avoid``; the one nearest ``anchor_s`` wins, whole minutes
    first, earlier first at a tie.

    Raises:
        WindowNotFound: no start gives exactly ``count``.
    """
    dep = np.sort(np.asarray(departures_s, dtype=float))
    starts = np.arange(0.0, day_s - length_s + 1.0)
    for lo, hi in avoid:
        starts = starts[(starts + length_s <= lo) | (starts >= hi)]
    counts = np.searchsorted(dep, starts + length_s, side="left") - np.searchsorted(dep, starts, side="left")
    ok = starts[counts == count]
    if ok.size == 0:
        found = f"between {counts.min()} and {counts.max()}" if counts.size else "no window left"
        raise WindowNotFound(f"no {format_clock(length_s)} window holds exactly {count} departures ({found})")
    minutes = ok[ok % 60 == 0]
    pool = minutes if minutes.size else ok
    return float(pool[np.argmin(np.abs(pool - anchor_s))])


def day_schedule_csv(network: Network, config: SynthConfig) -> str:
    """The synthetic day as schedule CSV text (the contract format)."""
    result = synthesize(network, config)
    buf = io.StringIO()
    write_schedule(result.flights, buf)
    return buf.getvalue()


def draw_source(config: SynthConfig) -> str:
    """The schedule a draw stands for, as the ``uam2scn synth`` command that writes it."""
    flags = f"--seed {config.seed}"
    if config.demand.daily_requests != DemandModel().daily_requests:
        flags += f" --daily-requests {config.demand.daily_requests:g}"
    if config.flight_prefix != SynthConfig().flight_prefix:
        flags += f" --prefix {config.flight_prefix}"
    name = "nyc_schedule.csv" if config == DAY_DRAW else f"nyc_schedule_{config.seed}.csv"
    return f"{name} (uam2scn synth {flags})"


def _draw_text(config: SynthConfig) -> str:
    extra = ""
    if config.demand.daily_requests != DemandModel().daily_requests:
        extra += f", {config.demand.daily_requests:g} trip requests a day"
    if config.flight_prefix != SynthConfig().flight_prefix:
        extra += f", flight ids {config.flight_prefix}nnnn"
    return f"seed {config.seed}, fleet {config.fleet_size}{extra}"


def regenerate(
    out_dir: Path, schedule_out: Path | None = None, config: SynthConfig | None = None
) -> list[tuple[Path, int, float]]:
    """Write the shipped scenarios into ``out_dir``.

    Args:
        out_dir: where to write them.
        schedule_out: also write the training day's schedule CSV here.
        config: replaces the training day's configuration (:data:`DAY_DRAW`); the evaluation
            day is always :data:`EVAL_DRAW`.

    Returns:
        (path, flights written, window start [s]) for each scenario.
    """
    network = nyc_network()
    schedules = {}
    for spec in SHIPPED:
        draw = config if config is not None and spec.draw == DAY_DRAW else spec.draw
        if draw in schedules:
            continue
        csv_text = day_schedule_csv(network, draw)
        if schedule_out is not None and spec.draw == DAY_DRAW:
            schedule_out.write_text(csv_text, encoding="utf-8")
        schedule = parse_schedule(io.StringIO(csv_text, newline=""), network, draw_source(draw))
        if schedule.errors:
            raise RuntimeError(f"the generator wrote invalid rows: {schedule.errors[0]}")
        schedules[draw] = schedule
    out_dir.mkdir(parents=True, exist_ok=True)
    windows: dict[str, tuple[float, float]] = {}
    written = []
    for spec in SHIPPED:
        draw = config if config is not None and spec.draw == DAY_DRAW else spec.draw
        schedule = schedules[draw]
        departures = np.array([f.departure_s for f in schedule.flights])
        start, end = 0.0, None
        if spec.length_s is not None and spec.flights is not None:
            avoid = (windows[spec.disjoint_from],) if spec.disjoint_from is not None else ()
            start = find_window(departures, spec.length_s, spec.flights, spec.anchor_s, draw.day_s, avoid)
            end = start + spec.length_s
        windows[spec.filename] = (start, end if end is not None else draw.day_s)
        window = f"Window: {format_clock(start)} to {format_clock(end if end is not None else draw.day_s)} of the day"
        if spec.disjoint_from is not None:
            lo, hi = windows[spec.disjoint_from]
            window += f", clear of {spec.disjoint_from}'s {format_clock(lo)} to {format_clock(hi)} (another day)"
        header = (
            spec.title,
            f"Generated by `uam2scn scenarios` (synthetic UAMToolkit, {_draw_text(draw)}); do not edit by hand.",
            window + ".",
        )
        options = ConvertOptions(
            start_s=start,
            end_s=end,
            alt_noise_ft=ALT_NOISE_FT,
            aircraft_type=AIRCRAFT_TYPE,
            seed=NOISE_SEED,
            header=header,
        )
        conversion = convert(schedule, network, options)
        path = out_dir / spec.filename
        path.write_text(conversion.text, encoding="utf-8")
        written.append((path, len(conversion.written), start))
    return written


def default_output_dir() -> Path:
    """``aamsim/scn`` of the aamsim package that is imported."""
    from aamsim.scenarios import packaged_dir

    return packaged_dir()
