"""Run a scenario in BlueSky headless and print what happened as JSON (used by the tests).

Usage: python bluesky_runner.py SCENARIO.scn WORKDIR UNTIL_S OUT.json

BlueSky keeps process-wide state, so the tests run this in a subprocess.
The JSON (written to OUT.json: BlueSky prints to stdout) holds, per aircraft: the creation time, the deletion time (None
when still flying), the last seen position, and the altitude range [ft]
flown after creation; plus the ECHO messages (errors included) that
BlueSky sent.
"""

from __future__ import annotations

import json
import sys


def main() -> None:
    scenario, workdir, until, out = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
    import bluesky as bs

    bs.init(mode="sim", detached=True, workdir=workdir)
    echoes: list[str] = []

    def send(topic, data=None, *args, **kwargs):
        if topic == b"ECHO" or topic == "ECHO":
            echoes.append(str(data.get("text", data)) if isinstance(data, dict) else str(data))

    bs.net.send = send
    bs.stack.stack(f"IC {scenario}")
    seen: dict[str, dict] = {}
    while bs.sim.simt < until:
        bs.sim.step()
        t = float(bs.sim.simt)
        ids = list(bs.traf.id)
        for k, acid in enumerate(ids):
            alt_ft = float(bs.traf.alt[k]) / 0.3048
            rec = seen.setdefault(
                acid,
                {
                    "created_s": t,
                    "deleted_s": None,
                    "alt_min_ft": alt_ft,
                    "alt_max_ft": alt_ft,
                    "first": [float(bs.traf.lat[k]), float(bs.traf.lon[k])],
                },
            )
            rec["last"] = [float(bs.traf.lat[k]), float(bs.traf.lon[k])]
            rec["alt_min_ft"] = min(rec["alt_min_ft"], alt_ft)
            rec["alt_max_ft"] = max(rec["alt_max_ft"], alt_ft)
        present = set(ids)
        for acid, rec in seen.items():
            if rec["deleted_s"] is None and acid not in present:
                rec["deleted_s"] = t
    with open(out, "w") as fh:
        json.dump({"aircraft": seen, "echo": echoes}, fh)


if __name__ == "__main__":
    main()
