"""Write ``aamsim/traffic/data/openap_fixwing.json``: BlueSky's OpenAP fixed-wing coefficients.

BlueSky 1.1.1 flies fixed-wing aircraft with its OpenAP performance model,
whose numbers come from the ``openap`` package (aircraft and engine
properties, WRAP kinematic envelopes, drag polars) through BlueSky's own
loader, which also derives the take-off and landing drag polars from the flap
data. This script asks that loader for every type it knows and writes the
numbers aamsim's model (:mod:`aamsim.traffic.openap`) uses, so that aamsim
flies each type with exactly BlueSky's coefficients without importing BlueSky
or OpenAP at run time.

Types whose coefficients are identical (OpenAP's synonyms: an A124 flies as a
B744) are written once, the others as ``aliases``.

Run it again after upgrading ``bluesky-simulator`` or ``openap``:

    python scripts/openap_performance_table.py
"""

from __future__ import annotations

import argparse
import json
import warnings
from importlib import metadata
from pathlib import Path

OUTPUT = Path(__file__).resolve().parent.parent / "aamsim" / "traffic" / "data" / "openap_fixwing.json"
BANK_DEG = 25.0  # BlueSky's default bank angle in turns (its OpenAP phase bank angles are not used in turns)


def _entry(code: str, limits: dict, aircraft: dict, polar: dict) -> dict:
    engine = next(iter(aircraft["engines"].values()))
    return {
        "name": aircraft["aircraft"],
        "lift": "fixwing",
        # The en-route CAS range is what BlueSky gives an aircraft when it is created.
        "vmin_mps": limits["vminer"],
        "vmax_mps": limits["vmaxer"],
        "mmo": limits["mmo"],
        # BlueSky's "descent limit" is the least of the WRAP climb rates, a positive number:
        # kept, as BlueSky's limits and its MVP resolution use it (docs/performance.md).
        "vsmin_mps": limits["vsmin"],
        "vsmax_mps": limits["vsmax"],
        "hmax_m": limits["hmax"],
        "axmax_mps2": limits["axmax"],
        "bank_deg": BANK_DEG,
        "openap": {
            "mass_kg": 0.5 * (aircraft["oew"] + aircraft["mtow"]),
            "wing_area_m2": aircraft["wing"]["area"],
            "max_thrust_n": int(aircraft["engine"]["number"]) * engine["max_thrust"],
            "bypass_ratio": engine["bpr"],
            "cd0_clean": polar["cd0_clean"],
            "k_clean": polar["k_clean"],
            "cd0_takeoff": float(polar["cd0_to"]),
            "k_takeoff": float(polar["k_to"]),
            "cd0_landing": float(polar["cd0_ld"]),
            "k_landing": float(polar["k_ld"]),
            "cd0_gear": polar["delta_cd_gear"],
            "vminto_mps": limits["vminto"],
            "vmaxic_mps": limits["vmaxic"],
            "vminap_mps": limits["vminap"],
            "vmaxap_mps": limits["vmaxap"],
        },
    }


def build() -> dict:
    warnings.simplefilter("ignore")  # OpenAP's and BlueSky's import-time chatter
    from bluesky.traffic.performance.openap.coeff import Coefficient
    from openap import prop

    coeff = Coefficient()
    types: dict[str, dict] = {}
    first_of: dict[str, str] = {}  # the entry's numbers -> the code that carries them
    # OpenAP's own types first, so that a synonym becomes the alias of the type it flies as.
    native = {c.upper() for c in prop.available_aircraft(use_synonym=False)}
    codes = sorted({c.upper() for c in coeff.actypes_fixwing}, key=lambda c: (c not in native, c))
    for code in codes:
        entry = _entry(code, coeff.limits_fixwing[code], coeff.acs_fixwing[code], coeff.dragpolar_fixwing[code])
        key = json.dumps({k: v for k, v in entry.items() if k != "name"}, sort_keys=True)
        base = first_of.get(key)
        if base is None:
            first_of[key] = code
            types[code] = entry
        else:
            types[base].setdefault("aliases", []).append(code)
    versions = f"openap {metadata.version('openap')}, bluesky-simulator {metadata.version('bluesky-simulator')}"
    for entry in types.values():
        entry["source"] = f"OpenAP, as BlueSky's OpenAP model loads it ({versions})"
    return {
        "_about": ("Fixed-wing types of BlueSky's OpenAP performance model: envelope limits (SI units, "
                   "CAS and Mach) and the thrust and drag coefficients of aamsim.traffic.openap. Written by "
                   "scripts/openap_performance_table.py; do not edit by hand."),
        "types": types,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=OUTPUT, help="where to write the table")
    args = parser.parse_args()
    table = build()
    args.output.write_text(json.dumps(table, indent=1) + "\n")
    print(f"{len(table['types'])} fixed-wing types "
          f"({sum(len(e.get('aliases', [])) for e in table['types'].values())} aliases) -> {args.output.name}")


if __name__ == "__main__":
    main()
