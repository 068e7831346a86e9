"""What a batch runs: scenarios (files or BlueSky ``SCEN`` blocks) x settings x seeds.

A BlueSky batch file is a scenario file holding several scenarios, each
starting at a ``SCEN name`` line and running to the next one; BlueSky's
server hands each block, with its times as written, to a free simulation
node. :func:`scenario_sources` splits a file the same way, so a file with no
or one ``SCEN`` line is one scenario, and a batch file is many.

Settings come from ``--set KEY=VALUE`` options: a key given several times is
a sweep axis, and the batch runs the cartesian product of all axes (in the
order the keys first appear), each with every seed.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aamsim.clock import TimeStepError, validate_dt
from aamsim.conflicts.service import SeparationVolume
from aamsim.stack.parser import scenario_lines
from aamsim.units import UnitParseError, parse_time


class BatchError(ValueError):
    """A batch cannot be planned (missing scenario, unknown setting, bad value)."""


@dataclass(frozen=True)
class ScenarioSource:
    """One scenario of a batch: a whole file, or one ``SCEN`` block of a batch file."""

    name: str
    path: Path  # the file it came from: its folder is where PCALL looks
    text: str
    first_line: int = 1  # line of ``path`` where the scenario starts


_UNSAFE_IN_FOLDER_NAME = re.compile(r"[^A-Za-z0-9_.,=+-]+")
FOLDER_NAME_MAX_CHARS = 120
NAME_MAX_CHARS = FOLDER_NAME_MAX_CHARS - 10  # a scenario's name, before a "-k" making it unique


def folder_name(text: str) -> str:
    """``text`` made safe as the name of one folder inside the batch folder.

    Only letters, digits and ``_.,=+-`` are kept (a run of anything else, ``/`` and
    ``\\`` included, becomes one ``_``), at most :data:`FOLDER_NAME_MAX_CHARS`, and a
    name starting with a dot gets a ``_`` in front: ``.``, ``..`` and the empty name
    never name a folder outside the batch folder or a hidden one.
    """
    safe = _UNSAFE_IN_FOLDER_NAME.sub("_", text)[:FOLDER_NAME_MAX_CHARS]
    return "_" + safe[: FOLDER_NAME_MAX_CHARS - 1] if not safe or safe.startswith(".") else safe


def _command_word(line: str) -> str:
    """Upper-case command name of a scenario line, '' for comments and blank lines."""
    body = line.split("#", 1)[0].strip()
    if not body:
        return ""
    if ">" in body:
        body = body.split(">", 1)[1].strip()
    return body.split(None, 1)[0].split(",", 1)[0].upper() if body else ""


def scenario_sources(path: Path, text: str) -> tuple[list[ScenarioSource], list[str]]:
    """Split a file into its scenarios (``SCEN`` blocks) and warnings for lines outside any block.

    Lines before the first ``SCEN`` of a file that has at least two belong to
    no scenario of the batch; BlueSky would run them as a scenario named
    after their second word, which is never what was meant, so they are
    reported and left out.
    """
    lines = scenario_lines(text, keepends=True)  # line numbers as an editor shows them
    starts = [k for k, line in enumerate(lines) if _command_word(line) in ("SCEN", "SCENARIO")]
    warnings: list[str] = []
    if len(starts) < 2:
        return [ScenarioSource(_safe_name(path.stem, str(path), warnings), path, text)], warnings
    stray = [k + 1 for k in range(starts[0]) if _command_word(lines[k])]
    if stray:
        warnings.append(f"{path}:{stray[0]}: {len(stray)} command line(s) before the first SCEN belong to no "
                        f"scenario of the batch; left out")
    sources = []
    seen: dict[str, int] = {}
    for begin, end in zip(starts, [*starts[1:], len(lines)]):
        words = lines[begin].split("#", 1)[0].split(">", 1)[-1].replace(",", " ").split()
        given = words[1] if len(words) > 1 else f"{path.stem}-{begin + 1}"
        name = _safe_name(given, f"{path}:{begin + 1}", warnings)
        seen[name] = seen.get(name, 0) + 1
        if seen[name] > 1:
            warnings.append(f"{path}:{begin + 1}: scenario name {name!r} used again; this one is {name}-{seen[name]}")
            name = f"{name}-{seen[name]}"
        # Blank lines in front keep the parser's line numbers equal to the batch file's.
        sources.append(ScenarioSource(name, path, "\n" * begin + "".join(lines[begin:end]), begin + 1))
    return sources, warnings


def _safe_name(name: str, where: str, warnings: list[str]) -> str:
    """The scenario's name as it names its run folders, with a warning when it had to change.

    A ``SCEN ../../x`` or ``SCEN /tmp/x`` line must not put run directories outside ``--out``.
    """
    safe = folder_name(name)[:NAME_MAX_CHARS]  # room for the "-2" that makes a repeated name unique
    if safe != name:
        warnings.append(f"{where}: scenario name {name[:80]!r} is not a plain folder name; the scenario is named "
                        f"{safe!r}")
    return safe


# ---------------------------------------------------------------- settings

def volume_from_text(name: str, text: str) -> SeparationVolume:
    """``RADIUS`` (sphere) or ``RADIUS,HALF_HEIGHT`` (cylinder), positive metres."""
    parts = [p for p in text.split(",") if p.strip()]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise BatchError(f'{name}="{text}": expected RADIUS or RADIUS,HALF_HEIGHT in metres') from None
    if len(values) not in (1, 2) or not all(math.isfinite(v) and v > 0 for v in values):
        raise BatchError(f'{name}="{text}": expected RADIUS or RADIUS,HALF_HEIGHT, positive metres')
    return SeparationVolume(name, values[0], values[1] if len(values) == 2 else None)


def _positive_float(key: str, text: str, allow_zero: bool = False) -> float:
    try:
        value = float(text)
    except ValueError:
        raise BatchError(f'{key}="{text}": not a number') from None
    if not math.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        raise BatchError(f'{key}="{text}": must be a {"non-negative" if allow_zero else "positive"} number')
    return value


def _time_step(key: str, text: str) -> float:
    """The time step [s], checked as ``aamsim run --dt`` checks it (``dt=1e300`` used to run)."""
    value = _positive_float(key, text)
    try:
        return validate_dt(value)
    except TimeStepError as exc:
        raise BatchError(f'{key}="{text}": {exc}') from None


def _flag(key: str, text: str) -> bool:
    low = text.strip().lower()
    if low in ("1", "true", "yes", "on"):
        return True
    if low in ("0", "false", "no", "off"):
        return False
    raise BatchError(f'{key}="{text}": expected true or false')


def _until(key: str, text: str) -> float:
    try:
        return parse_time(text)
    except UnitParseError as exc:
        raise BatchError(f"{key}: {exc}") from None


# key -> (RunConfig field it sets, parser, help)
SETTINGS: dict[str, tuple[str, Any, str]] = {
    "dt": ("dt_s", _time_step, "time step [s]"),
    "until": ("until_s", _until, "stop at this sim time (s or HH:MM:SS)"),
    "nmac": ("nmac", volume_from_text, "NMAC volume [m]: RADIUS or RADIUS,HALF_HEIGHT"),
    "lowc": ("lowc", volume_from_text, "LoWC volume [m]: RADIUS or RADIUS,HALF_HEIGHT"),
    "log_period": ("log_period_s", lambda k, t: _positive_float(k, t, allow_zero=True),
                   "trajectory sample period [s], 0: no trajectories.csv"),
    "delete_on_arrival": ("delete_on_arrival", _flag, "aircraft delete themselves at the end of their route"),
    "stack": ("commands", lambda k, t: t, "a stack command run at time 0 before the scenario (e.g. 'ZONER 0.3')"),
}


@dataclass(frozen=True)
class Setting:
    """One point of the sweep: the ``--set`` values as given, in key order."""

    values: tuple[tuple[str, str], ...] = ()

    @property
    def label(self) -> str:
        return ",".join(f"{k}={v}" for k, v in self.values) or "default"

    @property
    def dirname(self) -> str:
        """The label made safe as one folder name."""
        return folder_name(self.label)

    def run_config_fields(self) -> dict[str, Any]:
        """RunConfig keyword arguments for this setting (values parsed)."""
        out: dict[str, Any] = {}
        volumes: dict[str, SeparationVolume] = {}
        commands: list[str] = []
        for key, text in self.values:
            field_name, parse, _ = SETTINGS[key]
            value = parse(key, text)
            if field_name in ("nmac", "lowc"):
                volumes[field_name] = value
            elif field_name == "commands":
                commands.append(value)
            else:
                out[field_name] = value
        if volumes:
            out["volumes"] = (volumes.get("nmac") or volume_from_text("nmac", "150"),
                              volumes.get("lowc") or volume_from_text("lowc", "450"))
        if commands:
            out["commands"] = tuple(commands)
        return out


def load_sources(paths: Sequence[Path]) -> tuple[list[ScenarioSource], list[str]]:
    """The scenarios of every file, names made unique across files (they name the run folders)."""
    sources: list[ScenarioSource] = []
    warnings: list[str] = []
    used: set[str] = set()
    for path in paths:
        try:
            text = path.read_text(encoding="utf-8", errors="replace")
        except OSError as exc:
            raise BatchError(f"{path}: cannot read: {exc.strerror or exc}") from None
        found, notes = scenario_sources(path, text)
        warnings.extend(notes)
        for source in found:
            name, k = source.name, 1
            while name in used:
                k += 1
                name = f"{source.name}-{k}"
            used.add(name)
            sources.append(source if name == source.name else
                           ScenarioSource(name, source.path, source.text, source.first_line))
    return sources, warnings


def parse_settings(items: Sequence[str]) -> list[Setting]:
    """``KEY=VALUE`` items -> the sweep's settings (cartesian product over keys given several times)."""
    axes: dict[str, list[str]] = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip().lower()
        if not sep or not key:
            raise BatchError(f'--set "{item}": expected KEY=VALUE')
        if key not in SETTINGS:
            raise BatchError(f'--set "{item}": unknown key {key!r}; known: {", ".join(SETTINGS)}')
        if value.strip() in axes.get(key, []):  # the same run twice, in one folder: the second overwrote the first
            raise BatchError(f'--set "{item}": given twice')
        axes.setdefault(key, []).append(value.strip())
    points = [Setting(tuple(zip(axes, combo))) for combo in itertools.product(*axes.values())]
    for point in points:  # refuse bad values before anything runs
        point.run_config_fields()
    return points or [Setting()]


@dataclass(frozen=True)
class BatchJob:
    """One run of the batch."""

    index: int
    source: ScenarioSource
    setting: Setting
    seed: int
    base: dict[str, Any] = field(default_factory=dict)  # RunConfig fields common to every job

    @property
    def relpath(self) -> str:
        """Where its run directory goes inside the batch folder (always inside it, whatever the names)."""
        return f"{folder_name(self.source.name)}/{self.setting.dirname}/seed-{int(self.seed)}"


def plan_jobs(sources: Sequence[ScenarioSource], settings: Sequence[Setting], seeds: Sequence[int],
              base: dict[str, Any] | None = None) -> list[BatchJob]:
    """Every scenario x setting x seed, scenario-major (the order of the aggregate table)."""
    jobs: list[BatchJob] = []
    for source, setting, seed in itertools.product(sources, settings, seeds):
        jobs.append(BatchJob(len(jobs), source, setting, seed, dict(base or {})))
    return jobs
