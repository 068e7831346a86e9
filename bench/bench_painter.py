"""The matplotlib painter (``render_mode="rgb_array"``, videos): images per second at N aircraft.

Draws frames of N aircraft over the New York map of ``nyc_train_100.scn``
(the map every NYC scenario shares): positions spread over the map, each
aircraft flying straight at 60 m/s, ten sim seconds between frames (an env
step), about 5 % in LoWC, 1 % in NMAC and 2 % holding, with the painter's own
trails. The first frames warm matplotlib up and are not timed.

    python bench/bench_painter.py                          # 100 and 1,000 aircraft, 640 x 640
    python bench/bench_painter.py --aircraft 100 1000 2000 --size 800 --seconds 5
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from aamsim.render.draw import TrafficPainter
from aamsim.scenarios import resolve_scenario
from aamsim.viewer.frames import (
    STATUS_HOLDING,
    STATUS_LOWC,
    STATUS_NMAC,
    STATUS_NORMAL,
    TrafficFrame,
    layout_from_scenario,
)


def frames(n: int, bounds: tuple[float, float, float, float], seed: int = 0):
    """Endless frames of ``n`` aircraft flying straight over ``bounds``, 10 s apart."""
    rng = np.random.default_rng(seed)
    lat0, lat1, lon0, lon1 = bounds
    lat = rng.uniform(lat0, lat1, n)
    lon = rng.uniform(lon0, lon1, n)
    trk = rng.uniform(0.0, 360.0, n)
    status = rng.choice([STATUS_NORMAL, STATUS_LOWC, STATUS_NMAC, STATUS_HOLDING], n,
                        p=[0.92, 0.05, 0.01, 0.02]).astype(np.int8)
    ids = tuple(f"UAM{k:04d}" for k in range(n))
    dlat = 10.0 * 60.0 * np.cos(np.radians(trk)) / 111_320.0
    dlon = 10.0 * 60.0 * np.sin(np.radians(trk)) / (111_320.0 * np.cos(np.radians(0.5 * (lat0 + lat1))))
    t = 0.0
    while True:
        yield TrafficFrame(t, ids, lat.copy(), lon.copy(), np.full(n, 300.0), trk, np.full(n, 60.0), status,
                           metrics={"airborne": n, "nmac": 3, "lowc": 40, "completed": 120})
        t += 10.0
        lat, lon = lat + dlat, lon + dlon


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--aircraft", type=int, nargs="+", default=[100, 1000])
    ap.add_argument("--size", type=int, default=640, help="image width and height [pixels]")
    ap.add_argument("--seconds", type=float, default=3.0, help="wall time timed per aircraft count")
    args = ap.parse_args()
    path = resolve_scenario("nyc_train_100.scn")
    assert path is not None
    layout = layout_from_scenario(path.read_text())
    print(f"painter, {args.size} x {args.size} pixels, load {os.getloadavg()[0]:.1f}")
    print("| aircraft | images per second | ms per image |")
    print("|---|---|---|")
    for n in args.aircraft:
        painter = TrafficPainter(layout, args.size, args.size, title="bench")
        stream = frames(n, layout.bounds)
        for _ in range(5):  # warm-up: fonts, the first Agg render
            painter.paint(next(stream))
        count, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < args.seconds:
            image = painter.paint(next(stream))
            count += 1
        dt = time.perf_counter() - t0
        assert image.shape == (args.size, args.size, 3)
        print(f"| {n:,} | {count / dt:.0f} | {1000 * dt / count:.1f} |")
        painter.close()


if __name__ == "__main__":
    main()
