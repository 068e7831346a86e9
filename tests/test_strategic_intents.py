"""4-D intent reservation: closest approach of straight-line intents against the closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rlbridge.usecases.reservation import R_EARTH_M, Frame, Intent, IntentTable


def straight(lat0: float, lon0: float, lat1: float, lon1: float, duration_s: float) -> Intent:
    t = np.linspace(0.0, duration_s, 201)
    f = t / duration_s
    return Intent(t, lat0 + f * (lat1 - lat0), lon0 + f * (lon1 - lon0), 0.0, "O", "D", 0.0)


def test_perpendicular_crossing_closest_approach_is_v_delta_over_root_two():
    # A flies north through (0, 0), B east through it, both 2,224 m in 100 s (v = 22.24 m/s) and
    # reaching the crossing at 50 s. B departing d seconds later passes at v d / sqrt(2) from A.
    v = R_EARTH_M * math.radians(0.02) / 100.0
    north, east = straight(-0.01, 0, 0.01, 0, 100.0), straight(0, -0.01, 0, 0.01, 100.0)
    table = IntentTable(Frame(0.0, 0.0), grid_s=5.0, separation_m=450.0)
    table.reserve("A", north, 0.0, 100.0)
    conflicts, closest = table.candidates([east, east], 0.0, 8, 1, np.array([100.0, 100.0 + 300.0]))
    delays = np.arange(8) * 5.0
    expected = v * delays / math.sqrt(2)
    assert closest[:, 0] == pytest.approx(expected, abs=1e-6)
    assert conflicts[:, 0].tolist() == [1, 1, 1, 1, 1, 1, 0, 0]  # 25 s: 393 m < 450 m; 30 s: 472 m
    assert closest[:, 1] == pytest.approx(np.hypot(expected, 300.0), abs=1e-6)  # a layer 300 m up
    assert conflicts[:, 1].tolist() == [1, 1, 1, 1, 1, 0, 0, 0]  # 20 s: 435 m 3-D; 25 s: 495 m


def test_a_flight_is_held_a_grid_step_around_its_ends():
    # B departs from the point A's intent ends at, 3 s after A ends: inside the one-step padding.
    a = straight(-0.01, 0, 0.0, 0, 50.0)
    b = straight(0.0, 0, 0.0, 0.01, 50.0)
    table = IntentTable(Frame(0.0, 0.0), grid_s=5.0, separation_m=450.0)
    table.reserve("A", a, 0.0, 0.0)
    conflicts, closest = table.candidates([b], 53.0, 3, 1, np.array([0.0]))
    assert conflicts[:, 0].tolist() == [1, 1, 0]  # at 53 s and 58 s; at 63 s A is gone
    assert closest[0, 0] == pytest.approx(0.0, abs=1e-6)
