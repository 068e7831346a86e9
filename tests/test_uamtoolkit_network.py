"""The network file: loading, validation errors, GeoJSON, routes and lanes."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import pytest

from uamtoolkit_import.netfile import (
    NetworkError,
    load_network,
    nyc_network,
    nyc_network_path,
    parse_network,
    to_geojson,
)


def small_network() -> dict:
    return {
        "format": "uamtoolkit-network",
        "scenario_prefix": "T",
        "default_lanes_ft": [500, 1000],
        "vertiports": [
            {"id": "A", "lat": 40.70, "lon": -74.00},
            {"id": "B", "lat": 40.75, "lon": -74.00},
            {"id": "C", "lat": 40.72, "lon": -73.98},
        ],
        "nodes": [{"id": "N1", "lat": 40.72, "lon": -74.00}],
        "segments": [
            {"from": "A", "to": "N1"},
            {"from": "N1", "to": "B", "lanes_ft": [500, 1000, 1500]},
            {"from": "A", "to": "C"},
            {"from": "C", "to": "B", "lanes_ft": [1000]},
        ],
    }


def test_nyc_network_has_29_vertiports_all_connected():
    net = nyc_network()
    assert len(net.vertiports) == 29
    for key in ("DMH", "E34", "W30", "JFK", "LGA", "EWR", "TEB"):
        assert key in net.vertiports
    for o, d in itertools.permutations(net.vertiports, 2):
        path = net.shortest_path(o, d)
        assert path is not None and path[0] == o and path[-1] == d
        # Vertiports are where paths end, never waypoints in between.
        assert not set(path[1:-1]) & set(net.vertiports)
        assert net.route_lanes(path), f"{o}-{d} has no common lane"


def test_nyc_lanes_are_stacked_below_2000_ft_and_spaced_beyond_the_noise():
    lanes = sorted({lane for s in nyc_network().segments for lane in s.lanes_ft})
    assert len(lanes) >= 3 and max(lanes) < 2000
    assert min(b - a for a, b in itertools.pairwise(lanes)) > 2 * 100


def test_route_lanes_are_the_intersection_along_the_path():
    net = parse_network(small_network())
    assert net.route_lanes(["A", "N1", "B"]) == (500.0, 1000.0)
    assert net.route_lanes(["A", "C", "B"]) == (1000.0,)
    with pytest.raises(KeyError):
        net.route_lanes(["A", "B"])


def test_shortest_path_does_not_fly_through_a_vertiport():
    data = small_network()
    data["nodes"][0]["lon"] = -73.97  # A-N1-B is now 7.5 km ...
    data["vertiports"][2].update(lat=40.725, lon=-74.0)  # ... and A-C-B, through vertiport C, 5.6 km
    net = parse_network(data)
    assert net.path_length_m(["A", "C", "B"]) < net.path_length_m(["A", "N1", "B"])
    assert net.shortest_path("A", "B") == ["A", "N1", "B"]
    assert net.shortest_path("A", "C") == ["A", "C"]


def test_path_length_is_the_geodesic_sum():
    net = parse_network(small_network())
    assert net.path_length_m(["A", "N1", "B"]) == pytest.approx(5550.0, rel=0.005)  # 0.05 deg of latitude


def test_geojson_round_trip(tmp_path: Path):
    net = nyc_network()
    path = tmp_path / "nyc.geojson"
    path.write_text(json.dumps(to_geojson(net)))
    again = load_network(path)
    assert again.vertiports == net.vertiports
    assert again.nodes == net.nodes
    assert [(s.a, s.b, s.lanes_ft) for s in again.segments] == [(s.a, s.b, s.lanes_ft) for s in net.segments]
    assert again.scenario_prefix == net.scenario_prefix


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d["vertiports"][1].pop("lat"), "vertiports[1]: missing key 'lat'"),
        (lambda d: d["vertiports"][0].update(lat="north"), "vertiports[0].lat: 'north' is not a number"),
        (lambda d: d["vertiports"][0].update(lon=200), "vertiports[0].lon: 200 is outside"),
        (lambda d: d["nodes"][0].update(id="A"), "nodes[0].id: duplicate id 'A'"),
        (lambda d: d["segments"][1].update(to="ZZ"), "segments[1].to: unknown node or vertiport 'ZZ'"),
        (lambda d: d["segments"][0].update(lanes_ft=[]), "segments[0].lanes_ft: lanes must be a non-empty list"),
        (lambda d: d.pop("default_lanes_ft"), "segments[0]: missing key 'lanes_ft'"),
        (lambda d: d.pop("segments"), "top level: missing key 'segments'"),
        (lambda d: d.update(format="other"), "format: expected 'uamtoolkit-network'"),
        (lambda d: d.update(scenario_prefix="N_Y"), "scenario_prefix"),
    ],
)
def test_bad_network_names_file_and_key(tmp_path: Path, mutate, message):
    data = small_network()
    mutate(data)
    path = tmp_path / "net.json"
    path.write_text(json.dumps(data))
    with pytest.raises(NetworkError) as exc:
        load_network(path)
    assert str(exc.value).startswith(f"{path}: ")
    assert message in str(exc.value)


def test_unreadable_or_invalid_json_is_a_network_error(tmp_path: Path):
    with pytest.raises(NetworkError, match="cannot read"):
        load_network(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    with pytest.raises(NetworkError, match=r"bad.json: not valid JSON \(line 1"):
        load_network(bad)


def test_shipped_network_file_is_package_data():
    assert nyc_network_path().name == "nyc_network.json" and nyc_network_path().is_file()
