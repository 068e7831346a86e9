"""Run aamsim on a conformance scenario and compare it with BlueSky's recorded state.

The references (``reference/<name>.json``) are written by
``bench/bluesky_reference.py``; see its docstring. Run this module to print
the per-scenario errors::

    python tests/conformance/conformance_check.py [name ...]
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from functools import reduce
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENARIOS = HERE / "scenarios"
REFERENCES = HERE / "reference"

if __name__ == "__main__":  # run as a script from anywhere: use this checkout's aamsim
    sys.path.insert(0, str(HERE.parent.parent))

from aamsim import Simulation
from aamsim.geo import geodesic_inverse
from aamsim.stack.queue import to_us
from aamsim.traffic import fields as f
from aamsim.units import KTS

# Issue 2's agreement criteria.
POS_FRACTION = 0.01  # of the distance flown
POS_STRAIGHT_M = 50.0  # on straight segments
POS_FLOOR_M = 0.05  # rounding of the stored reference (1e-9 deg) and float noise
ALT_TOL_M = 5.0
SPD_TOL_KT = 0.5
STRAIGHT_TRK_DEG = 0.01  # a track that never changed by more than this since creation counts as straight

_STATE = {
    "lat": f.LAT, "lon": f.LON, "alt": f.ALT, "tas": f.TAS, "cas": f.CAS, "gs": f.GS,
    "hdg": f.HDG, "trk": f.TRK, "vs": f.VS, "distflown": f.DISTFLOWN,
}


def load_reference(name: str) -> dict:
    return json.loads((REFERENCES / f"{name}.json").read_text())


def run_aamsim(path: Path, times: list[float]) -> dict[int, dict[str, dict[str, float]]]:
    """State of every aircraft after the step that reaches each time [us -> acid -> field -> value]."""
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.load_scenario(path)
    wanted = [to_us(t) for t in times]
    interval_us = reduce(math.gcd, wanted)
    states: dict[int, dict[str, dict[str, float]]] = {}
    wanted_set = set(wanted)

    def sample(s: Simulation) -> None:
        # post_step hooks run after the step that reached simt, before the commands due at simt.
        if s.simt_us in wanted_set:
            F = s._traffic.F
            states[s.simt_us] = {
                acid: {name: float(F[row, i]) for name, row in _STATE.items()}
                for i, acid in enumerate(s.view.ids)
            }

    sim.hooks.post_step.add(sample, interval_s=interval_us / 1e6, name="conformance-sample")
    sim.run_until(times[-1])
    errors = [str(m) for m in sim.reporter.messages if m.kind == "error"]
    if errors:
        raise AssertionError(f"{path.name}: aamsim reported errors: {errors}")
    return states


@dataclass
class AircraftErrors:
    """Largest differences of one aircraft over all samples, and the failures."""

    pos_m: float = 0.0
    pos_frac: float = 0.0  # largest position error / distance flown
    alt_m: float = 0.0
    spd_kt: float = 0.0  # max over TAS, CAS and ground speed
    trk_deg: float = 0.0
    failures: list[str] = field(default_factory=list)


@dataclass
class Comparison:
    name: str
    aircraft: dict[str, AircraftErrors]
    missing: list[str]  # "t: ids only in one simulator"

    @property
    def failures(self) -> list[str]:
        out = list(self.missing)
        for acid, err in self.aircraft.items():
            out.extend(f"{acid} {msg}" for msg in err.failures)
        return out

    def worst(self) -> AircraftErrors:
        w = AircraftErrors()
        for e in self.aircraft.values():
            w.pos_m, w.pos_frac = max(w.pos_m, e.pos_m), max(w.pos_frac, e.pos_frac)
            w.alt_m, w.spd_kt, w.trk_deg = max(w.alt_m, e.alt_m), max(w.spd_kt, e.spd_kt), max(w.trk_deg, e.trk_deg)
        return w


def compare(name: str) -> Comparison:
    """Run scenario ``name`` in aamsim and compare it with its BlueSky reference."""
    ref = load_reference(name)
    times = [row["t"] for row in ref["samples"]]
    ours = run_aamsim(SCENARIOS / f"{name}.scn", times)
    result: dict[str, AircraftErrors] = {}
    missing = []
    first_trk: dict[str, float] = {}
    straight: dict[str, bool] = {}
    for row in ref["samples"]:
        t = row["t"]
        state = ours.get(to_us(t), {})
        if set(row["ids"]) != set(state):
            missing.append(f"t={t:g}: BlueSky has {sorted(set(row['ids']) - set(state))} "
                           f"aamsim has {sorted(set(state) - set(row['ids']))} in addition")
        for k, acid in enumerate(row["ids"]):
            bs = {name: row[name][k] for name in _STATE}
            # Straight so far: BlueSky's track has not moved since the aircraft appeared.
            first_trk.setdefault(acid, bs["trk"])
            turned = abs((bs["trk"] - first_trk[acid] + 180.0) % 360.0 - 180.0) > STRAIGHT_TRK_DEG
            straight[acid] = straight.get(acid, True) and not turned
            if acid not in state:
                continue
            us = state[acid]
            err = result.setdefault(acid, AircraftErrors())
            _, pos = geodesic_inverse(bs["lat"], bs["lon"], us["lat"], us["lon"])
            flown = max(bs["distflown"], us["distflown"])
            tol = POS_FRACTION * flown + POS_FLOOR_M
            if straight[acid]:
                tol = min(tol, POS_STRAIGHT_M)
            dalt = abs(bs["alt"] - us["alt"])
            dspd = max(abs(bs[q] - us[q]) for q in ("tas", "cas", "gs")) / KTS
            dtrk = abs((bs["trk"] - us["trk"] + 180.0) % 360.0 - 180.0)
            err.pos_m = max(err.pos_m, pos)
            if flown > 0:
                err.pos_frac = max(err.pos_frac, pos / flown)
            err.alt_m, err.spd_kt, err.trk_deg = max(err.alt_m, dalt), max(err.spd_kt, dspd), max(err.trk_deg, dtrk)
            if pos > tol:
                err.failures.append(f"t={t:g}: position off by {pos:.2f} m (tolerance {tol:.2f} m)")
            if dalt > ALT_TOL_M:
                err.failures.append(f"t={t:g}: altitude off by {dalt:.2f} m")
            if dspd > SPD_TOL_KT:
                err.failures.append(f"t={t:g}: speed off by {dspd:.3f} kt")
    return Comparison(name, result, missing)


def scenario_names() -> list[str]:
    return sorted(p.stem for p in SCENARIOS.glob("*.scn") if (REFERENCES / f"{p.stem}.json").exists())


def main(names: list[str]) -> int:
    bad = 0
    print(f"{'scenario':<18} {'aircraft':>8} {'max pos m':>10} {'pos/flown':>10} {'max alt m':>10} "
          f"{'max spd kt':>10} {'max trk deg':>11}  result")
    for name in names or scenario_names():
        c = compare(name)
        w = c.worst()
        ok = not c.failures
        bad += not ok
        print(f"{name:<18} {len(c.aircraft):>8} {w.pos_m:>10.2e} {w.pos_frac:>10.2e} {w.alt_m:>10.2e} "
              f"{w.spd_kt:>10.2e} {w.trk_deg:>11.2e}  {'ok' if ok else 'FAIL'}")
        if "-v" in sys.argv:
            for acid, e in c.aircraft.items():
                print(f"    {acid:<8} pos {e.pos_m:9.2e} m alt {e.alt_m:9.2e} m spd {e.spd_kt:9.2e} kt "
                      f"trk {e.trk_deg:9.2e} deg")
        for msg in c.failures[:10]:
            print("    " + msg)
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main([a for a in sys.argv[1:] if not a.startswith("-")]))
