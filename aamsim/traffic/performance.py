"""Aircraft performance envelopes, read from ``traffic/data/performance.json``.

An envelope is a kinematic limit set: speed range, vertical-rate range,
ceiling, longitudinal acceleration and default bank angle. Rotorcraft (and
the eVTOL types) limit TAS and may hover; fixed-wing types limit CAS and
Mach, as BlueSky's OpenAP model does. An unknown type gets the table's
``default_type`` (B744, as in BlueSky) and the caller is told so it can warn.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path


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


class PerformanceTable:
    """Type code (or alias) -> :class:`Envelope`."""

    def __init__(self, path: str | Path | None = None):
        if path is None:
            text = resources.files("aamsim.traffic").joinpath("data/performance.json").read_text()
        else:
            text = Path(path).read_text()
        data = json.loads(text)
        self._envelopes: dict[str, Envelope] = {}
        self._aliases: dict[str, str] = {}
        for code, entry in data["types"].items():
            code = code.upper()
            rotor = entry["lift"] == "rotor"
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
            )
            self._envelopes[code] = env
            for alias in entry.get("aliases", []):
                self._aliases[alias.upper()] = code
        self.default_type: str = data["default_type"].upper()
        if self.default_type not in self._envelopes:
            raise ValueError(f"default_type {self.default_type} is not in the performance table")

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
