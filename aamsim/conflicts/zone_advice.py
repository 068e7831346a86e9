"""A warning when BlueSky's airliner protected zone is used on rotorcraft-scale traffic.

BlueSky's conflict detection defaults to a protected zone of 5 NM and
1,000 ft (``ZONER``, ``ZONEDH``), sized for airliners. Urban air mobility
traffic (rotorcraft at 60 to 140 kt, vertiports a few km apart) is almost all
in conflict under it: ``ASAS ON`` counts nearly every pair, and ``RESO MVP``
pushes aircraft miles away from their routes (issue 26 item 9: the 100-flight
New York scenario with ``ASAS ON`` and ``RESO MVP`` kept aircraft off their
destinations for days of sim time). The warning names the commands that set a
zone for such traffic.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aamsim.units import FT, KTS, NM

if TYPE_CHECKING:
    from aamsim.simapi import SimulationCore

AIRLINER_ZONER_M = 5.0 * NM  # BlueSky's default ZONER
AIRLINER_ZONEDH_M = 1000.0 * FT  # ... and ZONEDH
SLOW_MPS = 200.0 * KTS  # aircraft whose maximum speed is below this count as rotorcraft-scale
SHARE = 0.5  # warn when at least this share of the cooperative aircraft is rotorcraft-scale


def zone_advice(sim: SimulationCore) -> str | None:
    """The warning text when detection uses the airliner zone on mostly rotorcraft-scale traffic, else None."""
    st = sim.settings
    if st.cd_method == "OFF" or st.zoner_m != AIRLINER_ZONER_M or st.zonedh_m != AIRLINER_ZONEDH_M:
        return None
    view = sim.view
    coop = ~np.asarray(view.noncooperative)
    total = int(coop.sum())
    if total == 0:
        return None
    small = (np.asarray(view.rotor) | (np.asarray(view.vmax) < SLOW_MPS))[coop]
    count = int(small.sum())
    if count < SHARE * total:
        return None
    effect = ("RESO MVP pushes aircraft up to 5 NM off their routes, where their ATDIST conditions may never fire"
              if st.reso.upper() == "MVP" else "nearly every pair of such traffic is a conflict")
    return (f"conflict detection uses BlueSky's airliner protected zone (5 NM / 1000 ft, the ZONER and ZONEDH "
            f"defaults) while {count} of {total} aircraft are rotorcraft or slower than 200 kt: {effect}; "
            "set a zone for this traffic with ZONER [NM] and ZONEDH [ft], e.g. ZONER 0.243 and ZONEDH 1476 "
            "(450 m both ways, the paper's LoWC sphere)")
