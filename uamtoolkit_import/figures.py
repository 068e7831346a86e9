"""Traffic maps over a UAMToolkit network: the network as the map of ``aamsim figure`` (``uam2scn figure``).

The drawing itself lives in :mod:`aamsim.render.figure`; this module only
turns a :class:`~uamtoolkit_import.network.Network` into the map layout it
draws (vertiports, and every route segment as a leg), for runs whose
scenario does not carry the network (or to draw a different one).
"""

from __future__ import annotations

import numpy as np

from aamsim.viewer.frames import MapLayout, padded_bounds
from uamtoolkit_import.network import Network


def network_layout(network: Network) -> MapLayout:
    """The map of a network: its vertiports and segments, with bounds around both."""
    vertiports = tuple(sorted((v.id, v.lat, v.lon) for v in network.vertiports.values()))
    legs = []
    for seg in network.segments:
        (a_lat, a_lon), (b_lat, b_lon) = network.position(seg.a), network.position(seg.b)
        legs.append(np.array([[a_lat, a_lon], [b_lat, b_lon]]))
    lats = [v[1] for v in vertiports] + [float(x) for leg in legs for x in leg[:, 0]]
    lons = [v[2] for v in vertiports] + [float(x) for leg in legs for x in leg[:, 1]]
    return MapLayout(vertiports, tuple(legs), (), padded_bounds(lats, lons))
