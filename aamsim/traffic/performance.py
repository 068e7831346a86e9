"""Aircraft performance envelopes, read from ``traffic/data/performance.json``
and ``traffic/data/openap_fixwing.json``.

An envelope is a kinematic limit set: speed range, vertical-rate range,
ceiling, longitudinal acceleration and default bank angle. Rotorcraft (and
the eVTOL types) limit TAS and may hover; fixed-wing types limit CAS and
Mach, as BlueSky's OpenAP model does, and carry that model's thrust and drag
coefficients (:class:`OpenAPCoefficients`), with which
:mod:`aamsim.traffic.openap` refreshes their speed range and acceleration by
flight phase. An unknown type gets the table's ``default_type`` (B744, as in
BlueSky) and the caller is told so it can warn.
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class OpenAPCoefficients:
    """A fixed-wing type's numbers in BlueSky's OpenAP model (SI units; speeds CAS except ``vminto``)."""

    mass_kg: float
    wing_area_m2: float
    max_thrust_n: float  # static maximum thrust of all engines
    bypass_ratio: float
    cd0_clean: float
    k_clean: float
    cd0_takeoff: float
    k_takeoff: float
    cd0_landing: float
    k_landing: float
    cd0_gear: float
    vminto_mps: float  # take-off speed (TAS)
    vmaxic_mps: float  # initial-climb maximum, also on the ground
    vminap_mps: float  # approach range
    vmaxap_mps: float


@dataclass(frozen=True)
class Envelope:
    """Limits of one aircraft type (SI units)."""

    type_code: str
    name: str
    rotor: bool
    vmin_mps: float
    vmax_mps: float
    vsmin_mps: float
    vsmax_mps: float
    hmax_m: float
    axmax_mps2: float
    mmo: float
    bank_rad: float
    source: str = ""
    openap: OpenAPCoefficients | None = None  # fixed wing: the thrust and drag model


DEFAULT_TABLES = ("data/performance.json", "data/openap_fixwing.json")


@functools.lru_cache(maxsize=len(DEFAULT_TABLES))
def _packaged_table(name: str) -> dict[str, Any]:
    """A table shipped with the package, parsed once a process: every simulation (an episode of the
    environments is one) builds its table from these, and only reads them."""
    return json.loads(resources.files("aamsim.traffic").joinpath(name).read_text())  # type: ignore[no-any-return]


class PerformanceTable:
    """Type code (or alias) -> :class:`Envelope`.

    By default the rotorcraft table (``performance.json``, which also names the
    default type) and BlueSky's OpenAP fixed-wing types; ``path`` replaces both
    with one file of the same format.
    """

    def __init__(self, path: str | Path | None = None):
        if path is None:
            tables = [(name, _packaged_table(name)) for name in DEFAULT_TABLES]
        else:
            tables = [(str(path), json.loads(Path(path).read_text()))]
        self._envelopes: dict[str, Envelope] = {}
        self._aliases: dict[str, str] = {}
        for name, data in tables:
            for code, entry in data["types"].items():
                self._add(name, code.upper(), entry)
        self.default_type: str = tables[0][1]["default_type"].upper()
        if self.default_type not in self._envelopes:
            raise ValueError(f"default_type {self.default_type} is not in the performance table")

    def _add(self, table: str, code: str, entry: dict) -> None:
        if code in self._envelopes or code in self._aliases:
            raise ValueError(f"{table}: aircraft type {code} is defined twice")
        rotor = entry["lift"] == "rotor"
        openap = entry.get("openap")
        env = Envelope(
            type_code=code,
            name=entry.get("name", code),
            rotor=rotor,
            vmin_mps=float(entry["vmin_mps"]),
            vmax_mps=float(entry["vmax_mps"]),
            vsmin_mps=float(entry["vsmin_mps"]),
            vsmax_mps=float(entry["vsmax_mps"]),
            hmax_m=float(entry["hmax_m"]),
            axmax_mps2=float(entry["axmax_mps2"]),
            mmo=float(entry.get("mmo", math.inf)),
            bank_rad=math.radians(float(entry.get("bank_deg", 25.0))),
            source=entry.get("source", ""),
            openap=None if rotor or openap is None else OpenAPCoefficients(**{k: float(v) for k, v in openap.items()}),
        )
        self._envelopes[code] = env
        for alias in entry.get("aliases", []):
            alias = alias.upper()
            if alias in self._envelopes or alias in self._aliases:
                raise ValueError(f"{table}: aircraft type {alias} is defined twice")
            self._aliases[alias] = code

    def lookup(self, actype: str) -> tuple[Envelope, bool]:
        """Envelope for a type code or alias, and whether the type was known."""
        code = actype.upper()
        code = self._aliases.get(code, code)
        env = self._envelopes.get(code)
        if env is None:
            return self._envelopes[self.default_type], False
        return env, True

    def types(self) -> list[Envelope]:
        return [self._envelopes[k] for k in sorted(self._envelopes)]
