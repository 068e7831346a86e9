"""Who holds, and when: one episode of a baseline, airborne holding per aircraft and one aircraft's decisions.

The analysis behind docs/daa.md ("Why DAA held aircraft"): runs one episode of a
tactical baseline on a scenario and prints the aircraft with the most airborne
holding (time airborne below the holding-speed threshold), then, for
``--trace CALLSIGN``, every decision of that aircraft: time, action (-1: no
advisory), CAS, whether it is held by the baseline and its alert level.

    python scripts/holding_trace.py --policy daa --seed 0 --trace UAM1001
"""

from __future__ import annotations

import argparse

import numpy as np

from rlbridge.agents import make_actor
from rlbridge.core import EpisodeCore


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="nyc_train_100.scn")
    ap.add_argument("--usecase", default="corridor_sa")
    ap.add_argument("--policy", default="daa")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--top", type=int, default=10)
    ap.add_argument("--trace", default="", help="callsign whose decisions are printed")
    args = ap.parse_args()
    core = EpisodeCore(args.scenario, args.usecase, {})
    actor = make_actor({"kind": args.policy})
    rng = np.random.default_rng(0)
    result = core.reset(args.seed)
    trace: list[str] = []
    while not result.done:
        out = actor.act(result, core, rng, {})
        advise = np.ones(len(result.agents), bool) if out.advise is None else out.advise
        acts = {} if out.actions is None else {a: int(x) for a, x, g in zip(result.agents, out.actions, advise)
                                               if g and a in result.alive}
        sim = core.sim
        if args.trace and args.trace in result.alive and args.trace in sim.view:
            i = sim.view.slot(args.trace)
            level = int(actor.daa.alerts(sim).level[i]) if hasattr(actor, "daa") else -1
            held = args.trace in getattr(actor, "_held", {})
            trace.append(f"{sim.simt:7.0f} s  action {acts.get(args.trace, -1):2d}  CAS {sim.view.cas[i]:5.1f} m/s  "
                         f"held {held!s:5}  alert {level}  holding so far {sim.view.slow_s[i]:5.0f} s")
        result = core.step(acts)
    metrics = core.metrics()
    print(f"{args.policy} on {args.scenario}, seed {args.seed}: NMAC {metrics['safety']['nmac_events']}, "
          f"LoWC {metrics['safety']['lowc_events']}, airborne holding {metrics['operational']['airborne_holding_s']:.0f} s, "
          f"end {core.sim.simt:.0f} s")
    slow = sorted(((f.slow_s, f.acid) for f in core.sim.flights()), reverse=True)[: args.top]
    print("most holding [s]: " + ", ".join(f"{a} {s:.0f}" for s, a in slow if s > 0))
    print("\n".join(trace))


if __name__ == "__main__":
    main()
