"""Fly heading and altitude advisories of heading_altitude_sa on the BlueSky backend (used by the tests).

Usage: python bluesky_manoeuvre.py SCENARIO.scn OUT.json

BlueSky keeps process-wide state, so the tests run this in a subprocess. TA1 gets the advisory
(+40 deg, +500 ft) for three decisions, then resumes; TB2 resumes throughout. After each decision
the file holds BlueSky's own state of TA1 beside the mirror's intents.
"""

from __future__ import annotations

import json
import sys


def main() -> None:
    import rlbridge

    scenario, out = sys.argv[1], sys.argv[2]
    env = rlbridge.parallel_env(scenario, usecase="heading_altitude_sa", backend="bluesky", time_limit_s=600.0,
                                alt_noise_ft=0.0)
    uc = env.core.usecase
    advise = (uc.params.heading_offsets_deg.index(40.0) * uc.n_alt + uc.params.altitude_offsets_ft.index(500.0))
    env.reset(seed=0)
    bs = env.core.bs
    rows = []
    for k in range(6):
        ta1 = advise if k < 3 else uc.resume_action
        env.step({"TA1": ta1, "TB2": uc.resume_action})
        view = env.core.sim.view
        i = view.slot("TA1")
        b = list(bs.traf.id).index("TA1")
        rows.append({"action": ta1, "mirror_ap_trk": float(view.ap_trk[i]), "mirror_selalt": float(view.selalt[i]),
                     "mirror_lnav": bool(view.lnav[i]), "bs_trk": float(bs.traf.trk[b]),
                     "bs_alt": float(bs.traf.alt[b]), "bs_selalt": float(bs.traf.selalt[b]),
                     "bs_lnav": bool(bs.traf.swlnav[b]), "bs_aptrk": float(bs.traf.ap.trk[b]),
                     "own_alt": float(uc.ep.own_alt["TA1"])})
    with open(out, "w", encoding="utf-8") as fh:
        json.dump(rows, fh, indent=1)
    env.close()


if __name__ == "__main__":
    main()
