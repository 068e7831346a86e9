"""Error of aamsim's (BlueSky's) flat-earth position update against WGS-84.

aamsim moves aircraft as BlueSky does: every step, forward Euler on a sphere
of radius 6371 km, dlat = dt*v_north/R, dlon = dt*v_east/(R*cos(lat)). From
40.7N 74.0W at 120 kts, this script flies legs of 10, 50 and 100 km in
several directions, two ways:

* holding a heading: the exact path is the WGS-84 rhumb line of that
  heading (integrated here with a fine Runge-Kutta step); the table gives
  how far from its end point aamsim ends after the same distance;
* LNAV to a waypoint placed on the WGS-84 geodesic: guidance closes the loop,
  so the aircraft gets there; the table gives its largest distance from the
  geodesic on the way and how much sooner (-) or later (+) than
  length/speed it passes the waypoint.

    python bench/flat_earth_error.py [--lat 40.7] [--lengths 10,50,100]

docs/bluesky-differences.md quotes its output.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from aamsim import Simulation
from aamsim.geo import WGS84_A, WGS84_B, geodesic_forward, geodesic_inverse
from aamsim.traffic import fields as f
from aamsim.units import KTS

SPEED_KT = 120.0
DT = 0.05
_E2 = 1.0 - (WGS84_B / WGS84_A) ** 2


def rhumb_end(lat: float, lon: float, heading: float, length: float, step: float = 10.0) -> tuple[float, float]:
    """End of the WGS-84 rhumb line (constant heading) of ``length`` metres, by RK4 in arc length."""
    alpha = math.radians(heading)

    def rates(phi: float) -> tuple[float, float]:
        w = 1.0 - _E2 * math.sin(phi) ** 2
        meridional = WGS84_A * (1.0 - _E2) / w**1.5
        normal = WGS84_A / math.sqrt(w)
        return math.cos(alpha) / meridional, math.sin(alpha) / (normal * math.cos(phi))

    phi, lam = math.radians(lat), math.radians(lon)
    n = max(1, math.ceil(length / step))
    h = length / n
    for _ in range(n):
        k1 = rates(phi)
        k2 = rates(phi + 0.5 * h * k1[0])
        k3 = rates(phi + 0.5 * h * k2[0])
        k4 = rates(phi + h * k3[0])
        phi += h / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        lam += h / 6.0 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return math.degrees(phi), math.degrees(lam)


@dataclass
class LegError:
    heading_deg: float
    length_km: float
    hdg_end_error_m: float  # heading hold vs the WGS-84 rhumb line, same distance flown
    lnav_cross_max_m: float  # LNAV: largest distance from the WGS-84 geodesic
    lnav_time_error_s: float  # LNAV: time to pass the waypoint - length / speed


def _cross_track(lat0: float, lon0: float, azimuth: float, lat: float, lon: float) -> float:
    az, dist = geodesic_inverse(lat0, lon0, lat, lon)
    return abs(dist * math.sin(math.radians(az - azimuth)))


def leg_error(lat: float, lon: float, heading: float, length_km: float) -> LegError:
    """One leg at sea level (TAS = CAS, so the speed is constant from the start)."""
    length = length_km * 1000.0
    tas = SPEED_KT * KTS
    t_end = length / tas
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.stack(f"CRE A EC35 {lat} {lon} {heading} 0 {SPEED_KT}")
    sim.run_until(round(t_end / DT) * DT)
    flown = float(sim._traffic.F[f.DISTFLOWN, 0])
    true_lat, true_lon = rhumb_end(lat, lon, heading, flown)
    _, hdg_error = geodesic_inverse(true_lat, true_lon, float(sim.view.lat[0]), float(sim.view.lon[0]))

    wp_lat, wp_lon = geodesic_forward(lat, lon, heading, length)
    sim = Simulation(seed=0, use_bluesky_navdata=False)
    sim.stack(f"CRE B EC35 {lat} {lon} {heading} 0 {SPEED_KT}")
    sim.stack("ADDWPT B FLYOVER")
    sim.stack(f"ADDWPT B {wp_lat:.10f} {wp_lon:.10f}")
    passed: list[float] = []
    cross = [0.0]

    def watch(s: Simulation) -> None:
        if passed:
            return
        if not s._traffic.B[f.B_SWLNAV, 0]:  # the (last) waypoint was passed
            passed.append(s.simt)
        elif s.simt_us % 1_000_000 == 0:
            cross[0] = max(cross[0], _cross_track(lat, lon, heading, float(s.view.lat[0]),
                                                  float(s.view.lon[0])))

    sim.hooks.post_step.add(watch, interval_s=DT)
    sim.run_until(t_end * 1.05 + 10.0)
    return LegError(heading, length_km, hdg_error, cross[0], (passed[0] if passed else math.nan) - t_end)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--lat", type=float, default=40.7)
    parser.add_argument("--lon", type=float, default=-74.0)
    parser.add_argument("--lengths", default="10,50,100", help="leg lengths [km]")
    parser.add_argument("--headings", default="0,45,90,135", help="headings [deg]")
    args = parser.parse_args(argv)
    print(f"legs at {SPEED_KT:g} kts from {args.lat:g}N {abs(args.lon):g}{'W' if args.lon < 0 else 'E'}, "
          f"dt {DT:g} s, against WGS-84")
    print(f"{'hdg':>5} {'km':>5} | {'heading hold: end error m':>25} {'%':>7} | "
          f"{'LNAV: max off geodesic m':>24} {'time error s':>12} {'%':>7}")
    for length in (float(x) for x in args.lengths.split(",")):
        for heading in (float(x) for x in args.headings.split(",")):
            e = leg_error(args.lat, args.lon, heading, length)
            t_leg = length * 1000.0 / (SPEED_KT * KTS)
            print(f"{e.heading_deg:5.0f} {e.length_km:5.0f} | {e.hdg_end_error_m:25.1f} "
                  f"{100 * e.hdg_end_error_m / (length * 1000):6.3f}% | {e.lnav_cross_max_m:24.1f} "
                  f"{e.lnav_time_error_s:12.2f} {100 * e.lnav_time_error_s / t_leg:6.3f}%")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
