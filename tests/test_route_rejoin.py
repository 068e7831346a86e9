"""Can an aircraft turn onto a point, as LNAV flies it (aamsim.resolution.rejoin)? Hand geometry and the simulator."""

from __future__ import annotations

import math

import pytest

from aamsim import Simulation
from aamsim.geo import qdrdist
from aamsim.resolution.rejoin import can_turn_onto, east_north_m, turn_radius_m


def test_turn_radius_by_hand():
    # 110 kt (57.4 m/s) at 25 deg of bank: 57.4^2 / (9.80665 * tan 25 deg) = 3294.76 / 4.57292 = 720.5 m.
    assert turn_radius_m(57.4, 57.4, math.radians(25.0)) == pytest.approx(720.5, abs=0.05)
    assert turn_radius_m(57.4, 57.4, 0.0) == math.inf


@pytest.mark.parametrize("trk", [0.0, 90.0, 225.0])
def test_can_turn_onto_by_hand(trk):
    r = 1000.0

    def point(ahead: float, right: float) -> tuple[float, float]:  # east, north of a point ahead/right of the track
        t = math.radians(trk)
        return ahead * math.sin(t) + right * math.cos(t), ahead * math.cos(t) - right * math.sin(t)

    assert can_turn_onto(*point(5000.0, 0.0), trk, r)  # straight ahead
    # Abeam 1.5 km to either side: 0.5 km from the turn circle's centre (1 km to that side), inside the circle.
    assert not can_turn_onto(*point(0.0, 1500.0), trk, r)
    assert not can_turn_onto(*point(0.0, -1500.0), trk, r)
    # Abeam 3 km: 2 km from the centre; the bearing swings from 90 deg to 90 + asin(1/2) = 120 deg: 30 deg.
    assert can_turn_onto(*point(0.0, 3000.0), trk, r)
    assert can_turn_onto(*point(0.0, -3000.0), trk, r)
    # Straight behind at d: the final course is 180 deg + 2 atan(r / d) off the bearing, a swing of 2 atan(r / d):
    # 79.6 deg at 1.2 km (over the 75 deg allowed), 71.1 deg at 1.4 km.
    assert not can_turn_onto(*point(-1200.0, 0.0), trk, r)
    assert can_turn_onto(*point(-1200.0, 0.0), trk, r, max_swing_deg=80.0)
    assert can_turn_onto(*point(-1400.0, 0.0), trk, r)


# Points it can just turn onto, heading north at 110 kt (turn radius 721 m): abeam at 1.5 km the bearing swings by
# asin(721 / 779) = 68 deg.
@pytest.mark.parametrize(("dist_m", "bearing_deg"), [(700.0, 20.0), (900.0, 330.0), (1100.0, 40.0), (1100.0, 180.0),
                                                     (1500.0, 90.0), (1500.0, 270.0), (1500.0, 150.0)])
def test_a_point_it_can_turn_onto_is_reached_by_lnav(dist_m, bearing_deg):
    """The model against the simulator's autopilot: LNAV direct to a point called reachable passes within 0.05 NM."""
    lat0, lon0 = 40.75, -74.0
    dlat = math.degrees(dist_m * math.cos(math.radians(bearing_deg)) / 6371000.0)
    dlon = math.degrees(dist_m * math.sin(math.radians(bearing_deg)) / (6371000.0 * math.cos(math.radians(lat0))))
    sim = Simulation(seed=0)
    sim.stack(f"DEFWPT DD {lat0 + dlat:.7f} {lon0 + dlon:.7f}; CRE A EC35 {lat0} {lon0} 0 1000 110; VNAV A OFF")
    sim.run_until(0.1)
    east, north = east_north_m(lat0, lon0, lat0 + dlat, lon0 + dlon)
    radius = turn_radius_m(float(sim.view.tas[0]), float(sim.view.gs[0]), float(sim.view.bankdef[0]))
    assert can_turn_onto(east, north, float(sim.view.trk[0]), radius)
    sim.stack("DEST A DD; LNAV A ON")
    closest = math.inf
    while sim.simt < dist_m / 50.0 + 120.0:
        sim.run_until(sim.simt + 0.5)
        closest = min(closest, qdrdist(sim.view.lat[0], sim.view.lon[0], lat0 + dlat, lon0 + dlon)[1])
    assert closest < 0.05 * 1852.0
