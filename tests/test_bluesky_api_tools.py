"""``bluesky.tools.geo`` and ``aero`` of the shim beside BlueSky's own: the same numbers, bit for bit.

BlueSky's Python geo functions (``bluesky/tools/geo/_geo.py``, what bluesky-gym
gets) and its aero functions are called on the same inputs (hypothesis). The
hand-computed cases are in tests/test_bluesky_api.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aamsim.compat.bluesky.tools import aero, geo

real_geo = pytest.importorskip("bluesky.tools.geo._geo")
real_aero = pytest.importorskip("bluesky.tools.aero")
pytestmark = pytest.mark.bluesky

lats = st.floats(-80.0, 80.0)
lons = st.floats(-180.0, 180.0)
bearings = st.floats(0.0, 360.0)
dists = st.floats(0.0, 500.0)
alts = st.floats(0.0, 20000.0)
speeds = st.floats(0.0, 300.0)


def _same(a, b) -> None:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    assert np.array_equal(a, b, equal_nan=True), (a, b)


@settings(max_examples=300, deadline=None)
@given(lats, lons, lats, lons)
def test_geo_of_two_positions(lat1, lon1, lat2, lon2):
    for name in ("kwikdist", "kwikqdrdist", "qdrdist", "latlondist"):
        _same(getattr(geo, name)(lat1, lon1, lat2, lon2), getattr(real_geo, name)(lat1, lon1, lat2, lon2))


@settings(max_examples=200, deadline=None)
@given(lats, lons, bearings, dists)
def test_geo_positions_from_bearing_and_distance(lat, lon, qdr, dist):
    _same(geo.kwikpos(lat, lon, qdr, dist), real_geo.kwikpos(lat, lon, qdr, dist))
    _same(geo.qdrpos(lat, lon, qdr, dist), real_geo.qdrpos(lat, lon, qdr, dist))
    _same(geo.rwgs84(lat), real_geo.rwgs84(lat))
    _same(geo.wgsg(lat), real_geo.wgsg(lat))


@settings(max_examples=100, deadline=None)
@given(lats, lons, st.lists(st.tuples(lats, lons), min_size=1, max_size=8))
def test_geo_of_arrays_and_matrices(lat, lon, others):
    lat2 = np.array([o[0] for o in others])
    lon2 = np.array([o[1] for o in others])
    lat1, lon1 = np.float64(lat), np.float64(lon)
    for name in ("kwikdist_matrix", "kwikqdrdist_matrix"):  # MergeEnv: one position against the others
        _same(getattr(geo, name)(lat1, lon1, lat2, lon2), getattr(real_geo, name)(lat1, lon1, lat2, lon2))
    for name in ("kwikdist", "kwikqdrdist", "qdrdist"):
        _same(getattr(geo, name)(lat1, lon1, lat2, lon2), getattr(real_geo, name)(lat1, lon1, lat2, lon2))
    col, row = np.asmatrix(lat2).T, np.asmatrix(lat2)  # BlueSky's conflict code: every pair
    _same(geo.kwikdist_matrix(col, np.asmatrix(lon2).T, row, np.asmatrix(lon2)),
          real_geo.kwikdist_matrix(col, np.asmatrix(lon2).T, row, np.asmatrix(lon2)))


@settings(max_examples=200, deadline=None)
@given(speeds, alts)
def test_aero_conversions(spd, h):
    arr_spd, arr_h = np.array([spd, spd / 2]), np.array([h, h / 3])
    for name in ("vcas2tas", "vtas2cas", "vmach2tas", "vtas2mach", "vcasormach", "vcasormach2tas", "veas2tas"):
        _same(getattr(aero, name)(arr_spd, arr_h), getattr(real_aero, name)(arr_spd, arr_h))
    _same(aero.vatmos(arr_h), real_aero.vatmos(arr_h))
    for name in ("cas2tas", "tas2cas", "mach2tas", "tas2mach", "casormach", "casormach2tas", "mach2cas"):
        _same(getattr(aero, name)(spd, h), getattr(real_aero, name)(spd, h))
    _same(aero.atmos(h * 4), real_aero.atmos(h * 4))  # through the upper layers


def test_aero_constants():
    for name in ("kts", "ft", "fpm", "nm", "g0", "R", "p0", "rho0", "T0", "Tstrat", "gamma", "beta", "Rearth", "a0",
                 "casmach_thr", "lbs", "inch", "sqft"):
        assert getattr(aero, name) == getattr(real_aero, name), name
