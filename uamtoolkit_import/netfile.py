"""Network files: reading and validating JSON / GeoJSON networks, the shipped New York network.

The plain JSON layout (``format: "uamtoolkit-network"``) and its GeoJSON
equivalent are described in ``docs/uamtoolkit-format.md``. Every error names
the file and the offending key (``segments[3].to``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from uamtoolkit_import.fields import NAME_MAX_CHARS, POINT_ID_MAX_CHARS, text_problem
from uamtoolkit_import.network import Network, RouteNode, Segment, Vertiport

NETWORK_FORMAT = "uamtoolkit-network"


class NetworkError(ValueError):
    """A network file is malformed; the message names the file and the key."""


def _require(obj: Mapping[str, Any], key: str, where: str, source: str) -> Any:
    if key not in obj:
        raise NetworkError(f"{source}: {where}: missing key '{key}'")
    return obj[key]


def _number(value: Any, where: str, source: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise NetworkError(f"{source}: {where}: {value!r} is not a number")
    try:
        x = float(value)
    except ValueError:
        raise NetworkError(f"{source}: {where}: {value!r} is not a number") from None
    if not (math.isfinite(x) and lo <= x <= hi):
        raise NetworkError(f"{source}: {where}: {x:g} is outside [{lo:g}, {hi:g}]")
    return x


def _ident(value: Any, where: str, source: str) -> str:
    if not isinstance(value, (str, int)) or isinstance(value, bool) or not str(value).strip():
        raise NetworkError(f"{source}: {where}: {value!r} is not an identifier")
    return _text(str(value).strip(), where, source, POINT_ID_MAX_CHARS)


def _text(value: Any, where: str, source: str, max_chars: int = NAME_MAX_CHARS) -> str:
    """A name written into the scenario's comments: one line of printable text (``\\n`` would start a command)."""
    text = str(value)
    problem = text_problem(text, max_chars)
    if problem:
        raise NetworkError(f"{source}: {where}: {problem}")
    return text


def _lanes(value: Any, where: str, source: str) -> tuple[float, ...]:
    if not isinstance(value, list) or not value:
        raise NetworkError(f"{source}: {where}: lanes must be a non-empty list of altitudes in ft")
    lanes = sorted({_number(x, f"{where}[{k}]", source, 0.0, 60000.0) for k, x in enumerate(value)})
    return tuple(lanes)


def _objects(
    data: Mapping[str, Any], key: str, source: str, required: bool = True
) -> Iterator[tuple[str, Mapping[str, Any]]]:
    """The objects of the list ``data[key]``, each with its location (``key[k]``) for messages."""
    if required:
        raw = _require(data, key, "top level", source)
    else:
        raw = data.get(key, [])
    if not isinstance(raw, list):
        raise NetworkError(f"{source}: {key}: must be a list")
    for k, item in enumerate(raw):
        if not isinstance(item, Mapping):
            raise NetworkError(f"{source}: {key}[{k}]: must be an object")
        yield f"{key}[{k}]", item


def _position(item: Mapping[str, Any], where: str, source: str) -> tuple[float, float]:
    lat = _number(_require(item, "lat", where, source), f"{where}.lat", source, -90, 90)
    lon = _number(_require(item, "lon", where, source), f"{where}.lon", source, -180, 180)
    return lat, lon


def _parse_vertiports(data: Mapping[str, Any], source: str) -> dict[str, Vertiport]:
    vertiports: dict[str, Vertiport] = {}
    for where, item in _objects(data, "vertiports", source):
        vid = _ident(_require(item, "id", where, source), f"{where}.id", source)
        if vid in vertiports:
            raise NetworkError(f"{source}: {where}.id: duplicate id '{vid}'")
        lat, lon = _position(item, where, source)
        weight = _number(item.get("demand_weight", 1.0), f"{where}.demand_weight", source, 0.0)
        vertiports[vid] = Vertiport(
            vid,
            _text(item.get("name", vid), f"{where}.name", source),
            lat,
            lon,
            weight,
            bool(item.get("cbd", False)),
            _text(item.get("kind", "site"), f"{where}.kind", source),
        )
    if not vertiports:
        raise NetworkError(f"{source}: vertiports: must be a non-empty list")
    return vertiports


def _parse_nodes(data: Mapping[str, Any], source: str, vertiports: Mapping[str, Vertiport]) -> dict[str, RouteNode]:
    nodes: dict[str, RouteNode] = {}
    for where, item in _objects(data, "nodes", source, required=False):
        nid = _ident(_require(item, "id", where, source), f"{where}.id", source)
        if nid in nodes or nid in vertiports:
            raise NetworkError(f"{source}: {where}.id: duplicate id '{nid}'")
        lat, lon = _position(item, where, source)
        nodes[nid] = RouteNode(nid, lat, lon, _text(item.get("corridor", ""), f"{where}.corridor", source))
    return nodes


def _parse_segments(data: Mapping[str, Any], source: str, points: Mapping[str, object]) -> list[Segment]:
    default_lanes = data.get("default_lanes_ft")
    if default_lanes is not None:
        default_lanes = _lanes(default_lanes, "default_lanes_ft", source)
    segments: list[Segment] = []
    seen: set[frozenset[str]] = set()
    for where, item in _objects(data, "segments", source):
        ends = []
        for key in ("from", "to"):
            pid = _ident(_require(item, key, where, source), f"{where}.{key}", source)
            if pid not in points:
                raise NetworkError(f"{source}: {where}.{key}: unknown node or vertiport '{pid}'")
            ends.append(pid)
        if ends[0] == ends[1]:
            raise NetworkError(f"{source}: {where}: a segment needs two different ends")
        if frozenset(ends) in seen:
            raise NetworkError(f"{source}: {where}: duplicate segment {ends[0]}-{ends[1]}")
        seen.add(frozenset(ends))
        if "lanes_ft" in item:
            lanes = _lanes(item["lanes_ft"], f"{where}.lanes_ft", source)
        elif default_lanes is not None:
            lanes = default_lanes
        else:
            raise NetworkError(f"{source}: {where}: missing key 'lanes_ft' (and no 'default_lanes_ft')")
        segments.append(Segment(ends[0], ends[1], lanes, _text(item.get("corridor", ""), f"{where}.corridor", source)))
    return segments


def parse_network(data: Mapping[str, Any], source: str = "<network>") -> Network:
    """Build a :class:`Network` from the decoded JSON (either format).

    Raises:
        NetworkError: a key is missing or a value is invalid; the message
            names ``source`` and the offending key (e.g. ``segments[3].to``).
    """
    if not isinstance(data, Mapping):
        raise NetworkError(f"{source}: the top level must be a JSON object")
    if data.get("type") == "FeatureCollection":
        data = _geojson_to_plain(data, source)
    fmt = data.get("format", NETWORK_FORMAT)
    if fmt != NETWORK_FORMAT:
        raise NetworkError(f"{source}: format: expected '{NETWORK_FORMAT}', not {fmt!r}")
    vertiports = _parse_vertiports(data, source)
    nodes = _parse_nodes(data, source, vertiports)
    segments = _parse_segments(data, source, {**vertiports, **nodes})
    prefix = str(data.get("scenario_prefix", "UT")).upper()
    if not (prefix.isalnum() and prefix.isascii() and prefix[:1].isalpha() and len(prefix) <= 4):
        raise NetworkError(f"{source}: scenario_prefix: {prefix!r} must be 1-4 letters/digits, starting with a letter")
    name = _text(data.get("name", Path(source).stem), "name", source)
    return Network(name, vertiports, nodes, segments, prefix, source)


def _geojson_to_plain(data: Mapping[str, Any], source: str) -> dict[str, Any]:
    """A GeoJSON FeatureCollection -> the plain network layout.

    Point features with ``properties.role`` ``vertiport`` (or ``node``) and
    LineString features with ``properties.from``/``to`` (and ``lanes_ft``).
    Coordinates are GeoJSON's ``[lon, lat]``.
    """
    plain: dict[str, Any] = {"vertiports": [], "nodes": [], "segments": []}
    props_top = data.get("properties", {}) or {}
    for key in ("name", "scenario_prefix", "default_lanes_ft"):
        if key in props_top:
            plain[key] = props_top[key]
    for where, feat in _objects(data, "features", source):
        geom = _require(feat, "geometry", where, source) or {}
        props = dict(feat.get("properties") or {})
        gtype = geom.get("type") if isinstance(geom, Mapping) else None
        if gtype == "Point":
            coords = _require(geom, "coordinates", f"{where}.geometry", source)
            if not isinstance(coords, list) or len(coords) < 2:
                raise NetworkError(f"{source}: {where}.geometry.coordinates: expected [lon, lat]")
            role = str(_require(props, "role", f"{where}.properties", source)).lower()
            entry = {**props, "lon": coords[0], "lat": coords[1]}
            if role == "vertiport":
                plain["vertiports"].append(entry)
            elif role == "node":
                plain["nodes"].append(entry)
            else:
                raise NetworkError(f"{source}: {where}.properties.role: expected 'vertiport' or 'node', not {role!r}")
        elif gtype == "LineString":
            plain["segments"].append(props)
        else:
            raise NetworkError(f"{source}: {where}.geometry.type: expected Point or LineString, not {gtype!r}")
    return plain


def load_network(path: str | Path) -> Network:
    """Read a network file (JSON or GeoJSON).

    Raises:
        NetworkError: the file cannot be read or is malformed.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise NetworkError(f"{path}: cannot read the network file ({exc.strerror})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise NetworkError(f"{path}: not valid JSON (line {exc.lineno}: {exc.msg})") from None
    return parse_network(data, str(path))


def nyc_network_path() -> Path:
    """The shipped New York network file."""
    return Path(str(resources.files("uamtoolkit_import").joinpath("data", "nyc_network.json")))


def nyc_network() -> Network:
    """The shipped New York network (see ``docs/nyc-network.md``)."""
    return load_network(nyc_network_path())


def to_geojson(network: Network) -> dict[str, Any]:
    """The network as a GeoJSON FeatureCollection (readable by :func:`parse_network`)."""
    features: list[dict[str, Any]] = []
    for v in network.vertiports.values():
        props = {
            "role": "vertiport",
            "id": v.id,
            "name": v.name,
            "kind": v.kind,
            "demand_weight": v.demand_weight,
            "cbd": v.cbd,
        }
        features.append(
            {"type": "Feature", "geometry": {"type": "Point", "coordinates": [v.lon, v.lat]}, "properties": props}
        )
    for n in network.nodes.values():
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [n.lon, n.lat]},
                "properties": {"role": "node", "id": n.id, "corridor": n.corridor},
            }
        )
    for s in network.segments:
        (la, loa), (lb, lob) = network.position(s.a), network.position(s.b)
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": [[loa, la], [lob, lb]]},
                "properties": {"from": s.a, "to": s.b, "lanes_ft": list(s.lanes_ft), "corridor": s.corridor},
            }
        )
    return {
        "type": "FeatureCollection",
        "properties": {"name": network.name, "scenario_prefix": network.scenario_prefix},
        "features": features,
    }
