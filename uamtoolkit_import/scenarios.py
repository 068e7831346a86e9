"""The scenarios shipped in ``aamsim/scn/`` and how they are regenerated.

All three come from one synthetic day (:func:`uamtoolkit_import.synth.synthesize`
with the default configuration and the New York network), written as a
schedule in the contract format and converted by :func:`convert.convert`:

* ``nyc_day.scn``: the whole day from midnight;
* ``nyc_train_100.scn``: the 25-minute window holding exactly 100 departures
  whose start is nearest 08:00 (the morning peak), on a whole minute when
  possible (the paper's training scenario);
* ``nyc_eval_678.scn``: the 5-hour window holding exactly 678 departures
  whose start is nearest 04:00 (from the night into the morning peak; the
  paper's evaluation scenario).

``uam2scn scenarios`` rewrites them; the output is identical on every run.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from uamtoolkit_import.convert import ConvertOptions, convert
from uamtoolkit_import.netfile import nyc_network
from uamtoolkit_import.network import Network
from uamtoolkit_import.schedule import parse_schedule, write_schedule
from uamtoolkit_import.synth import SynthConfig, synthesize
from uamtoolkit_import.times import format_clock

ALT_NOISE_FT = 100.0
NOISE_SEED = 2022
AIRCRAFT_TYPE = "EC35"


@dataclass(frozen=True)
class ShippedScenario:
    """A shipped scenario: a window of the synthetic day.

    Attributes:
        filename: name in ``aamsim/scn/``.
        title: first comment line.
        length_s: window length [s] (None: the whole day from midnight).
        flights: exact number of departures the window must hold.
        anchor_s: the window start is chosen nearest this time of day [s].
    """

    filename: str
    title: str
    length_s: float | None = None
    flights: int | None = None
    anchor_s: float = 0.0


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
    ),
)


class WindowNotFound(ValueError):
    """No window of the asked length holds exactly the asked number of departures."""


def find_window(departures_s: np.ndarray, length_s: float, count: int, anchor_s: float, day_s: float) -> float:
    """Start [s] of a window ``[start, start + length_s)`` holding exactly ``count`` departures.

    Candidate starts are whole seconds in ``[0, day_s - length_s]``; the one
    nearest ``anchor_s`` wins, whole minutes first, earlier first at a tie.

    Raises:
        WindowNotFound: no start gives exactly ``count``.
    """
    dep = np.sort(np.asarray(departures_s, dtype=float))
    starts = np.arange(0.0, day_s - length_s + 1.0)
    counts = np.searchsorted(dep, starts + length_s, side="left") - np.searchsorted(dep, starts, side="left")
    ok = starts[counts == count]
    if ok.size == 0:
        raise WindowNotFound(
            f"no {format_clock(length_s)} window holds exactly {count} departures "
            f"(between {counts.min()} and {counts.max()})"
        )
    minutes = ok[ok % 60 == 0]
    pool = minutes if minutes.size else ok
    return float(pool[np.argmin(np.abs(pool - anchor_s))])


def day_schedule_csv(network: Network, config: SynthConfig) -> str:
    """The synthetic day as schedule CSV text (the contract format)."""
    result = synthesize(network, config)
    buf = io.StringIO()
    write_schedule(result.flights, buf)
    return buf.getvalue()


def regenerate(
    out_dir: Path, schedule_out: Path | None = None, config: SynthConfig | None = None
) -> list[tuple[Path, int, float]]:
    """Write the shipped scenarios into ``out_dir``.

    Returns:
        (path, flights written, window start [s]) for each scenario.
    """
    config = config or SynthConfig()
    network = nyc_network()
    csv_text = day_schedule_csv(network, config)
    if schedule_out is not None:
        schedule_out.write_text(csv_text, encoding="utf-8")
    source = f"nyc_schedule.csv (uam2scn synth --seed {config.seed})"
    schedule = parse_schedule(io.StringIO(csv_text, newline=""), network, source)
    if schedule.errors:
        raise RuntimeError(f"the generator wrote invalid rows: {schedule.errors[0]}")
    departures = np.array([f.departure_s for f in schedule.flights])
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for spec in SHIPPED:
        start, end = 0.0, None
        if spec.length_s is not None and spec.flights is not None:
            start = find_window(departures, spec.length_s, spec.flights, spec.anchor_s, config.day_s)
            end = start + spec.length_s
        header = (
            spec.title,
            (
                f"Generated by `uam2scn scenarios` (synthetic UAMToolkit, seed {config.seed}, "
                f"fleet {config.fleet_size}); do not edit by hand."
            ),
            f"Window: {format_clock(start)} to {format_clock(end if end is not None else config.day_s)} of the day.",
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
