"""Traffic maps of a run (PNG): the network, the flown trajectories, one moment's aircraft and where conflicts were.

Like the paper's figure of New York traffic: route legs in grey, vertiports as
labelled squares, flown trajectories as thin blue lines, the aircraft airborne
at one moment as arrows, and every LoWC and NMAC of the run as a dot at the
pair's mid-point in the viewer's status colours. Equirectangular projection
(longitude scaled by cos(latitude)) with a kilometre scale bar.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from aamsim.viewer.frames import STATUS_COLOURS, STATUS_LOWC, STATUS_NMAC, MapLayout, RunReplay

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def busiest_time(replay: RunReplay) -> float | None:
    """The sample time [s] with the most aircraft airborne (earliest at a tie)."""
    if not len(replay.times):
        return None
    return float(replay.times[int(np.argmax(replay.airborne_counts()))])


def plot_run(run_dir: str | Path, out: str | Path, *, title: str | None = None, snapshot_s: float | None = None,
             labels: bool = True, layout: MapLayout | None = None, every: int = 1,
             dpi: int = 150) -> tuple[Path, int]:
    """Draw ``run_dir``'s map into ``out`` (PNG); returns the path and the number of trajectories drawn.

    ``layout`` replaces the network read from the run's ``scenario.scn``
    (``uam2scn figure --network``); ``every`` keeps every n-th sample of each
    trajectory (and its last) to draw long runs faster.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    replay = RunReplay(run_dir)
    layout = layout or replay.layout()
    lat_min, lat_max, lon_min, lon_max = layout.bounds
    lat0 = (lat_min + lat_max) / 2
    fig = Figure(figsize=(10, 10))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_facecolor("#eef3f7")
    for line in layout.routes:
        ax.plot(line[:, 1], line[:, 0], color="#9a9a9a", lw=1.2, zorder=1)
    tracks = replay.trails(replay.t_end, replay.t_end - replay.t_start + 1.0)
    for pts in tracks.values():
        if every > 1:
            pts = np.vstack([pts[:-1:every], pts[-1:]])
        ax.plot(pts[:, 1], pts[:, 0], color="#1f5fbf", lw=0.5, alpha=0.35, zorder=2)
    if snapshot_s is not None:
        f = replay.frame_at(snapshot_s)
        if len(f):
            u = np.sin(np.radians(f.trk)) / math.cos(math.radians(lat0))
            v = np.cos(np.radians(f.trk))
            ax.quiver(f.lon, f.lat, u, v, color="#1a9a2a", scale=45, width=0.004, zorder=4,
                      label=f"in flight at t = {snapshot_s:.0f} s ({len(f)})")
    for code, name in ((STATUS_LOWC, "LoWC"), (STATUS_NMAC, "NMAC")):
        ev_lat, ev_lon = replay.event_positions(name.lower())
        if len(ev_lat):
            ax.scatter(ev_lon, ev_lat, s=14 if code == STATUS_LOWC else 22, color=STATUS_COLOURS[code],
                       edgecolor="black", linewidths=0.3, zorder=5, label=f"{name} ({len(ev_lat)})")
    if layout.vertiports:
        _, vlat, vlon = zip(*layout.vertiports)
        ax.scatter(vlon, vlat, marker="s", s=30, color="#5d6d7e", zorder=6, label="vertiports")
        if labels:
            for n, a, o in layout.vertiports:
                ax.annotate(n, (o, a), xytext=(4, 3), textcoords="offset points", fontsize=7, zorder=7)
    ax.plot([], [], color="#1f5fbf", lw=1, label=f"flown trajectories ({len(tracks)})")
    if layout.routes:
        ax.plot([], [], color="#9a9a9a", lw=1.2, label="route legs")
    ax.set_aspect(1.0 / math.cos(math.radians(lat0)))
    ax.set_xlim(lon_min, lon_max)
    ax.set_ylim(lat_min, lat_max)
    _scale_bar(ax, lat0)
    ax.set_xlabel("longitude [deg]")
    ax.set_ylabel("latitude [deg]")
    ax.grid(color="white", lw=0.8)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title(title or f"{replay.summary.get('scenario') or Path(run_dir).name}: {len(tracks)} flights",
                 fontsize=10)
    fig.tight_layout()
    path = Path(out)
    fig.savefig(path, dpi=dpi)
    return path, len(tracks)


def _scale_bar(ax: Axes, lat0: float, km: float = 5.0) -> None:
    """A ``km`` scale bar in the upper-left corner."""
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    dlon = km / (111.32 * math.cos(math.radians(lat0)))
    x = x0 + 0.04 * (x1 - x0)
    y = y1 - 0.05 * (y1 - y0)
    ax.plot([x, x + dlon], [y, y], color="black", lw=2.5)
    ax.annotate(f"{km:g} km", (x + dlon / 2, y), xytext=(0, 4), textcoords="offset points", ha="center", fontsize=8)
