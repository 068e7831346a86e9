"""The painter on hand-built frames: short trails by sim time, the legend and the scale bar."""

from __future__ import annotations

import numpy as np

from aamsim.render.draw import TRAIL_S, TrafficPainter, _round_length
from aamsim.viewer.frames import STATUS_COLOURS, STATUS_NMAC, MapLayout, TrafficFrame

LAYOUT = MapLayout((("VA", 40.70, -74.00), ("VB", 40.75, -74.00)), (np.array([[40.70, -74.0], [40.75, -74.0]]),),
                   (), (40.69, 40.76, -74.03, -73.97))


def _frame(t: float, lat: float, status: int = 0) -> TrafficFrame:
    one = np.array([1.0])
    return TrafficFrame(t, ("A1",), np.array([lat]), np.array([-74.0]), one * 300, one * 0.0, one * 50,
                        np.array([status], dtype=np.int8))


def test_trails_keep_the_last_minute_of_sim_time():
    painter = TrafficPainter(LAYOUT, 200, 200)
    for k in range(11):  # t = 0, 10, ..., 100 s
        painter.paint(_frame(10.0 * k, 40.70 + 0.004 * k))
    assert TRAIL_S == 60.0
    assert [p[0] for p in painter._history["A1"]] == [40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0]
    painter.paint(_frame(0.0, 40.70))  # a new episode: time went back
    assert [p[0] for p in painter._history["A1"]] == [0.0]


def test_the_legend_names_every_state_in_its_colour():
    painter = TrafficPainter(LAYOUT, 300, 300)
    image = painter.paint(_frame(5.0, 40.72, STATUS_NMAC))
    legend = painter.ax.get_legend()
    assert [t.get_text() for t in legend.get_texts()] == ["normal", "in LoWC", "in NMAC", "holding"]
    # Each colour appears in the legend's corner (lower right) even when no aircraft is in that state.
    corner = image[-80:, -100:].reshape(-1, 3).astype(int)
    for colour in STATUS_COLOURS:
        want = np.array([int(colour[k:k + 2], 16) for k in (1, 3, 5)])
        assert np.abs(corner - want).sum(axis=1).min() < 30, colour


def test_scale_bar_lengths_are_round():
    assert [_round_length(x) for x in (0.7, 1.0, 1.9, 2.2, 4.99, 5.0, 13.0, 460.0)] == \
        [0.5, 1.0, 1.0, 2.0, 2.0, 5.0, 10.0, 200.0]


def test_a_frame_drawn_over_the_kept_background_equals_a_fresh_drawing():
    """Blitting: nothing of the previous frame is left behind."""
    first, second = TrafficPainter(LAYOUT, 200, 200), TrafficPainter(LAYOUT, 200, 200)
    first.paint(_frame(0.0, 40.70, STATUS_NMAC), trails={})
    again = first.paint(_frame(10.0, 40.74), trails={})
    fresh = second.paint(_frame(10.0, 40.74), trails={})
    np.testing.assert_array_equal(again, fresh)
    assert not np.array_equal(again, first.paint(_frame(20.0, 40.73), trails={}))


def test_traffic_never_covers_the_legend_or_the_scale_bar():
    painter = TrafficPainter(LAYOUT, 300, 300)
    empty = painter.paint(TrafficFrame(0.0, (), *(np.empty(0),) * 5, np.empty(0, dtype=np.int8)))
    legend = painter.ax.get_legend().get_window_extent(painter.canvas.get_renderer())
    # an aircraft (in NMAC: red) right on the legend's middle
    x, y = painter.ax.transData.inverted().transform(((legend.x0 + legend.x1) / 2, (legend.y0 + legend.y1) / 2))
    lat, lon = y + painter.lat0, x / painter.cos0 + painter.lon0
    one = np.array([1.0])
    frame = TrafficFrame(1.0, ("A1",), np.array([lat]), np.array([lon]), one * 300, one * 0.0, one * 50,
                         np.array([STATUS_NMAC], dtype=np.int8))
    covered = painter.paint(frame)
    rows = slice(300 - int(legend.y1) + 1, 300 - int(legend.y0) - 1)
    cols = slice(int(legend.x0) + 1, int(legend.x1) - 1)
    np.testing.assert_array_equal(covered[rows, cols], empty[rows, cols])
    row, col = painter.pixel(lat, lon)
    assert rows.start < row < rows.stop and cols.start < col < cols.stop  # it was drawn there, then covered
