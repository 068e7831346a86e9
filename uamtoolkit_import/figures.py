"""Traffic maps: the network and the flown trajectories of a run (PNG).

Like the paper's figure of New York traffic: route segments in grey,
vertiports as labelled squares, flown trajectories as thin blue lines and
the aircraft airborne at one moment as green arrows. The map uses an
equirectangular projection (longitude scaled by cos(latitude)) so distances
look right, with a kilometre scale bar.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from uamtoolkit_import.network import Network

if TYPE_CHECKING:
    from matplotlib.axes import Axes


@dataclass(frozen=True)
class Track:
    """One aircraft's samples: time [s], lat/lon [deg], track [deg]."""

    acid: str
    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    trk: np.ndarray


def read_tracks(path: Path, every: int = 1) -> list[Track]:
    """Read ``trajectories.csv`` of an aamsim run (keeping every ``every``-th sample of each aircraft)."""
    columns: dict[str, list[list[float]]] = {}
    with open(path, newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            return []
        try:
            i_id, i_t, i_lat, i_lon = (header.index(k) for k in ("id", "simt", "lat", "lon"))
        except ValueError:
            raise ValueError(f"{path}: not an aamsim trajectories.csv (columns id, simt, lat, lon)") from None
        i_trk = header.index("trk_deg") if "trk_deg" in header else -1
        for row in reader:
            rows = columns.setdefault(row[i_id], [])
            rows.append(
                [float(row[i_t]), float(row[i_lat]), float(row[i_lon]), float(row[i_trk]) if i_trk >= 0 else math.nan]
            )
    tracks = []
    for acid, rows in columns.items():
        a = np.asarray(rows)
        if every > 1:
            keep = np.zeros(len(a), dtype=bool)
            keep[::every] = True
            keep[-1] = True
            a = a[keep]
        tracks.append(Track(acid, a[:, 0], a[:, 1], a[:, 2], a[:, 3]))
    return tracks


def busiest_time(tracks: list[Track]) -> float | None:
    """The sample time [s] with the most aircraft airborne (earliest at a tie)."""
    if not tracks:
        return None
    times, counts = np.unique(np.concatenate([t.t for t in tracks]), return_counts=True)
    return float(times[np.argmax(counts)])


def _snapshot(tracks: list[Track], t_s: float) -> Iterator[tuple[float, float, float]]:
    for tr in tracks:
        k = np.searchsorted(tr.t, t_s)
        if k < len(tr.t) and abs(tr.t[k] - t_s) < 1e-6:
            yield float(tr.lat[k]), float(tr.lon[k]), float(tr.trk[k])


def plot_traffic(
    network: Network,
    tracks: list[Track],
    out: Path,
    title: str = "",
    snapshot_s: float | None = None,
    labels: bool = True,
    dpi: int = 150,
) -> Path:
    """Draw the network and the trajectories into a PNG file; returns ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lats = [v.lat for v in network.vertiports.values()] + [n.lat for n in network.nodes.values()]
    lons = [v.lon for v in network.vertiports.values()] + [n.lon for n in network.nodes.values()]
    lat0 = float(np.mean(lats))
    fig, ax = plt.subplots(figsize=(10, 10))
    ax.set_facecolor("#eef3f7")
    for seg in network.segments:
        (a_lat, a_lon), (b_lat, b_lon) = network.position(seg.a), network.position(seg.b)
        access = seg.a in network.vertiports or seg.b in network.vertiports
        ax.plot(
            [a_lon, b_lon],
            [a_lat, b_lat],
            color="#9a9a9a",
            lw=0.8 if access else 1.6,
            ls=":" if access else "-",
            zorder=1,
        )
    for tr in tracks:
        ax.plot(tr.lon, tr.lat, color="#1f5fbf", lw=0.5, alpha=0.35, zorder=2)
    if snapshot_s is not None:
        snap = list(_snapshot(tracks, snapshot_s))
        if snap:
            s_lat, s_lon, s_trk = (np.array(x) for x in zip(*snap))
            u = np.sin(np.radians(s_trk)) / math.cos(math.radians(lat0))
            v = np.cos(np.radians(s_trk))
            ax.quiver(
                s_lon,
                s_lat,
                u,
                v,
                color="#1a9a2a",
                scale=45,
                width=0.004,
                zorder=4,
                label=f"in flight at t = {snapshot_s:.0f} s ({len(snap)})",
            )
    vlat = [v.lat for v in network.vertiports.values()]
    vlon = [v.lon for v in network.vertiports.values()]
    ax.scatter(vlon, vlat, marker="s", s=30, color="#c0392b", zorder=5, label="vertiports")
    if labels:
        for v in network.vertiports.values():
            ax.annotate(v.id, (v.lon, v.lat), xytext=(4, 3), textcoords="offset points", fontsize=7, zorder=6)
    ax.plot([], [], color="#1f5fbf", lw=1, label=f"flown trajectories ({len(tracks)})")
    ax.plot([], [], color="#9a9a9a", lw=1.6, label="route segments")
    ax.set_aspect(1.0 / math.cos(math.radians(lat0)))
    pad = 0.01
    ax.set_xlim(min(lons) - pad, max(lons) + pad)
    ax.set_ylim(min(lats) - pad, max(lats) + pad)
    _scale_bar(ax, lat0)
    ax.set_xlabel("longitude [deg]")
    ax.set_ylabel("latitude [deg]")
    ax.grid(color="white", lw=0.8)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title(title or network.name, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out


def _scale_bar(ax: Axes, lat0: float, km: float = 5.0) -> None:
    """A ``km`` scale bar in the upper-left corner."""
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    dlon = km / (111.32 * math.cos(math.radians(lat0)))
    x = x0 + 0.04 * (x1 - x0)
    y = y1 - 0.05 * (y1 - y0)
    ax.plot([x, x + dlon], [y, y], color="black", lw=2.5)
    ax.annotate(f"{km:g} km", (x + dlon / 2, y), xytext=(0, 4), textcoords="offset points", ha="center", fontsize=8)
