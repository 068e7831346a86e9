"""Draw a traffic frame into an RGB image with matplotlib: what ``render_mode="rgb_array"`` and videos show.

The same picture as the web viewer (:mod:`aamsim.viewer`): the scenario's
network on a dark map in a local equirectangular projection (longitude scaled
by the cosine of the central latitude, so a kilometre looks the same both
ways), aircraft as heading-oriented triangles in the status colours, short
trails, expanding rings where NMAC/LoWC events begin, and a line of numbers.

One :class:`TrafficPainter` keeps one figure and its artists, and only moves
their data from frame to frame: drawing a frame costs one Agg render, not a
new figure (figures per second in ``docs/viewer.md``).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from aamsim.viewer.frames import STATUS_COLOURS, STATUS_NAMES, MapLayout, TrafficFrame

BACKGROUND = "#0b1622"
ROUTE_COLOUR = "#2c4560"
COAST_COLOUR = "#4b5a3c"  # olive grey: land and water, apart from the blue network
TEXT_COLOUR = "#d6e2ee"
TRAIL_FRAMES = 20  # at most this many positions per trail when frames are fed one by one
TRAIL_S = 60.0  # and none older than this [s of sim time]: short trails whatever the time between frames
FLASH_S = 30.0  # sim seconds an event ring stays on screen


_LEGEND_NAMES = {"lowc": "in LoWC", "nmac": "in NMAC"}


def _round_length(km: float) -> float:
    """The largest 1, 2 or 5 times a power of ten not above ``km`` (a scale bar's length)."""
    p = 10.0 ** math.floor(math.log10(max(km, 1e-3)))
    return max(m * p for m in (1.0, 2.0, 5.0) if m * p <= max(km, p))


def _hhmmss(t: float) -> str:
    s = max(0.0, float(t))
    return f"{int(s // 3600):02d}:{int(s % 3600 // 60):02d}:{s % 60:04.1f}"


class TrafficPainter:
    """Paints :class:`~aamsim.viewer.frames.TrafficFrame` s over one :class:`~aamsim.viewer.frames.MapLayout`."""

    def __init__(self, layout: MapLayout, width: int = 800, height: int = 800, title: str = "") -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import LineCollection, PolyCollection
        from matplotlib.figure import Figure

        if width < 64 or height < 64:
            raise ValueError(f"an image needs at least 64 x 64 pixels, not {width} x {height}")
        self.layout = layout
        self.width, self.height = int(width), int(height)
        lat0, lat1, lon0, lon1 = layout.bounds
        self.lat0, self.lon0 = (lat0 + lat1) / 2, (lon0 + lon1) / 2
        self.cos0 = math.cos(math.radians(self.lat0))
        self.fig = Figure(figsize=(self.width / 100, self.height / 100), dpi=100, facecolor=BACKGROUND)
        self.canvas = FigureCanvasAgg(self.fig)
        ax = self.ax = self.fig.add_axes((0, 0, 1, 1))
        ax.set_facecolor(BACKGROUND)
        ax.set_axis_off()
        # Fit the bounds into the image with equal scales on both axes.
        x0, x1 = float(self._x(lon0)), float(self._x(lon1))
        y0, y1 = lat0 - self.lat0, lat1 - self.lat0
        span = max((x1 - x0) / self.width, (y1 - y0) / self.height)
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        ax.set_xlim(cx - span * self.width / 2, cx + span * self.width / 2)
        ax.set_ylim(cy - span * self.height / 2, cy + span * self.height / 2)
        self.size = 9.0 * span  # an aircraft symbol is about 18 pixels long
        for line in layout.outline:
            ax.plot(self._x(line[:, 1]), line[:, 0] - self.lat0, color=COAST_COLOUR, lw=1.0, zorder=1)
        for line in layout.routes:
            ax.plot(self._x(line[:, 1]), line[:, 0] - self.lat0, color=ROUTE_COLOUR, lw=0.8, zorder=1)
        if layout.vertiports:
            _, vlat, vlon = zip(*layout.vertiports)
            ax.scatter(self._x(np.array(vlon)), np.array(vlat) - self.lat0, marker="s", s=22,
                       facecolor=BACKGROUND, edgecolor="#9fb3c8", linewidths=0.9, zorder=2)
            for n, a, o in layout.vertiports:
                ax.annotate(n, (self._x(o), a - self.lat0), xytext=(4, 3), textcoords="offset points",
                            fontsize=6.5, color="#7f98b2", zorder=2)
        self.trails = LineCollection([], linewidths=0.9, zorder=3)
        self.aircraft = PolyCollection([], linewidths=0, zorder=4)
        self.rings = ax.scatter([], [], s=[], facecolors="none", linewidths=1.8, zorder=5)
        ax.add_collection(self.trails)
        ax.add_collection(self.aircraft)
        self.text = ax.text(0.015, 0.985, "", transform=ax.transAxes, va="top", ha="left", fontsize=9,
                            color=TEXT_COLOUR, family="monospace", zorder=6,
                            bbox={"boxstyle": "round,pad=0.3", "facecolor": BACKGROUND, "alpha": 0.75, "lw": 0})
        keys = self._legend()
        self.title = title
        self._history: dict[str, deque[tuple[float, float, float]]] = {}  # callsign -> (t, lat, lon)
        self._rings: list[tuple[float, float, float, str]] = []  # t, x, y, kind
        # The map, its labels, the legend and the scale bar never change: they are rendered once into a
        # background and each frame draws only the traffic over a copy of it (blitting: 100 aircraft 41 -> 136
        # images/s). The legend's and scale bar's pixels are then copied back over the traffic, and the text
        # line drawn last, so they stay legible over dense traffic.
        self._keys = keys
        self._moving = (self.trails, self.aircraft, self.rings)
        for artist in (*self._moving, self.text):
            artist.set_animated(True)
        self._background: Any = None
        self._key_boxes: list[tuple[int, int, int, int]] = []  # (x0, y0, x1, y1) pixels, origin top left

    def _legend(self) -> tuple[Any, ...]:
        """What the colours mean (lower right) and a kilometre scale bar (lower left): a video stands alone.

        Returns their artists."""
        from matplotlib.lines import Line2D

        handles = [Line2D([], [], marker="^", ls="", color=c, markersize=7, label=_LEGEND_NAMES.get(n, n))
                   for c, n in zip(STATUS_COLOURS, STATUS_NAMES)]
        legend = self.ax.legend(handles=handles, loc="lower right", fontsize=7.5, facecolor=BACKGROUND,
                                edgecolor=ROUTE_COLOUR, labelcolor=TEXT_COLOUR, framealpha=0.85, handletextpad=0.3)
        legend.set_zorder(6)
        x0, x1 = self.ax.get_xlim()
        y0, y1 = self.ax.get_ylim()
        km_per_unit = 111.32  # projected units are degrees of latitude
        km = _round_length(0.2 * (x1 - x0) * km_per_unit)
        x, y = x0 + 0.03 * (x1 - x0), y0 + 0.035 * (y1 - y0)
        (bar,) = self.ax.plot([x, x + km / km_per_unit], [y, y], color=TEXT_COLOUR, lw=2.0, zorder=6,
                              solid_capstyle="butt")
        label = self.ax.annotate(f"{km:g} km", (x + 0.5 * km / km_per_unit, y), xytext=(0, 4),
                                 textcoords="offset points", ha="center", fontsize=7.5, color=TEXT_COLOUR, zorder=6)
        return legend, bar, label

    def _x(self, lon: Any) -> Any:
        """Projected x of longitudes (an array or one number); y is latitude minus the central latitude."""
        return (lon - self.lon0) * self.cos0

    def triangles(self, frame: TrafficFrame) -> np.ndarray:
        """(n, 3, 2) triangle vertices (projected), nose along the track."""
        x, y = self._x(frame.lon), frame.lat - self.lat0
        a = np.radians(frame.trk)
        fx, fy = np.sin(a), np.cos(a)  # forward
        rx, ry = fy, -fx  # right
        s = self.size
        nose = np.stack([x + fx * s, y + fy * s], axis=-1)
        left = np.stack([x - fx * 0.6 * s - rx * 0.55 * s, y - fy * 0.6 * s - ry * 0.55 * s], axis=-1)
        right = np.stack([x - fx * 0.6 * s + rx * 0.55 * s, y - fy * 0.6 * s + ry * 0.55 * s], axis=-1)
        return np.stack([nose, right, left], axis=1)

    def paint(self, frame: TrafficFrame, trails: dict[str, np.ndarray] | None = None) -> np.ndarray:
        """The frame as an ``(height, width, 3)`` uint8 RGB image.

        ``trails`` (callsign -> (k, 2) lat/lon) replaces the painter's own
        history, which otherwise grows from the frames it is given.
        """
        colours = np.array(STATUS_COLOURS)[np.clip(frame.status.astype(int), 0, len(STATUS_COLOURS) - 1)]
        if trails is None:
            alive = set(frame.ids)
            for gone in [k for k in self._history if k not in alive]:
                del self._history[gone]
            oldest = frame.simt - TRAIL_S
            for acid, la, lo in zip(frame.ids, frame.lat.tolist(), frame.lon.tolist()):
                h = self._history.setdefault(acid, deque(maxlen=TRAIL_FRAMES))
                if h and h[-1][0] > frame.simt:  # time went back (a new episode): start the trail afresh
                    h.clear()
                h.append((frame.simt, la, lo))
                while h[0][0] < oldest:
                    h.popleft()
            trails = {k: np.array(v)[:, 1:] for k, v in self._history.items()}
        colour_of = dict(zip(frame.ids, colours.tolist()))
        segs = [np.column_stack([self._x(p[:, 1]), p[:, 0] - self.lat0]) for p in trails.values() if len(p) > 1]
        self.trails.set_segments(segs)
        self.trails.set_color([colour_of.get(k, STATUS_COLOURS[0]) for k, p in trails.items() if len(p) > 1])
        self.trails.set_alpha(0.45)
        self.aircraft.set_verts(list(self.triangles(frame)))
        self.aircraft.set_facecolor(colours.tolist())
        for e in frame.events:
            self._rings.append((e.t, float(self._x(e.lon)), e.lat - self.lat0, e.kind))
        self._rings = [r for r in self._rings if 0 <= frame.simt - r[0] < FLASH_S]
        if self._rings:
            age = np.array([(frame.simt - r[0]) / FLASH_S for r in self._rings])
            self.rings.set_offsets(np.array([[r[1], r[2]] for r in self._rings]))
            self.rings.set_sizes(60 + 900 * age)
            self.rings.set_edgecolor([STATUS_COLOURS[2 if r[3] == "nmac" else 1] for r in self._rings])
        else:
            self.rings.set_offsets(np.zeros((0, 2)))
        m = frame.metrics
        self.text.set_text(
            (f"{self.title}\n" if self.title else "")
            + f"t {_hhmmss(frame.simt)}  airborne {m.get('airborne', len(frame))}\n"
            + f"NMAC {m.get('nmac', '-')}  LoWC {m.get('lowc', '-')}  completed {m.get('completed', '-')}")
        if self._background is None:
            self.canvas.draw()  # animated artists are left out of a full draw
            self._background = self.canvas.copy_from_bbox(self.fig.bbox)
            self._key_boxes = [self._pixel_box(a) for a in self._keys]
        else:
            self.canvas.restore_region(self._background)
        for artist in self._moving:
            self.ax.draw_artist(artist)
        for x0, y0, x1, y1 in self._key_boxes:
            # Agg reads the box with its origin top left and ``xy`` as an offset from it (measured).
            self.canvas.restore_region(self._background, bbox=(x0, y0, x1, y1), xy=(0, 0))
        self.ax.draw_artist(self.text)
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()

    def _pixel_box(self, artist: Any, pad: int = 2) -> tuple[int, int, int, int]:
        """An artist's pixels as (x0, y0, x1, y1), origin top left (the Agg buffer's), padded, in the image."""
        ext = artist.get_window_extent(self.canvas.get_renderer())
        x0, x1 = max(0, int(ext.x0) - pad), min(self.width, math.ceil(ext.x1) + pad)
        y0, y1 = max(0, self.height - math.ceil(ext.y1) - pad), min(self.height, self.height - int(ext.y0) + pad)
        return x0, y0, x1, y1

    def pixel(self, lat: float, lon: float) -> tuple[int, int]:
        """Image (row, column) of a position: where a test looks for an aircraft's colour."""
        x, y = self.ax.transData.transform((float(self._x(lon)), lat - self.lat0))
        return round(self.height - y), round(x)

    def close(self) -> None:
        self.fig.clear()
