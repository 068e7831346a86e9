"""The vertiport network: vertiports, route nodes and laned route segments.

Networks are read from JSON or GeoJSON files by :mod:`uamtoolkit_import.netfile`
(formats in ``docs/uamtoolkit-format.md``). A :class:`Network` answers the questions the converter and the generator ask: where is a
node (degrees), which segment joins two nodes and which lanes (altitudes in
ft) it has, how long a route is (m, WGS-84 geodesic) and which is the
shortest route between two vertiports.

Vertiports are graph nodes too, but a shortest path never passes *through*
another vertiport: vertiports are where flights begin and end.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from itertools import pairwise

from aamsim.geo import geodesic_inverse


@dataclass(frozen=True)
class Vertiport:
    """A take-off and landing site.

    Attributes:
        id: identifier used in schedules.
        name: human-readable name.
        lat: latitude [deg]; lon: longitude [deg].
        demand_weight: relative trip generation (synthetic demand only).
        cbd: in a central business district (morning inbound, evening outbound peaks).
        kind: e.g. ``heliport``, ``airport``, ``site``.
    """

    id: str
    name: str
    lat: float
    lon: float
    demand_weight: float = 1.0
    cbd: bool = False
    kind: str = "site"


@dataclass(frozen=True)
class RouteNode:
    """A point of the route graph [deg]; ``corridor`` names the route it lies on."""

    id: str
    lat: float
    lon: float
    corridor: str = ""


@dataclass(frozen=True)
class Segment:
    """An undirected route segment between two nodes with its lanes [ft], lowest first."""

    a: str
    b: str
    lanes_ft: tuple[float, ...]
    corridor: str = ""


@dataclass
class Network:
    """A vertiport network. Build it with :func:`load_network` or :func:`parse_network`."""

    name: str
    vertiports: dict[str, Vertiport]
    nodes: dict[str, RouteNode]
    segments: list[Segment]
    scenario_prefix: str = "UT"
    source: str = "<network>"
    _adjacency: dict[str, dict[str, Segment]] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        for seg in self.segments:
            self._adjacency.setdefault(seg.a, {})[seg.b] = seg
            self._adjacency.setdefault(seg.b, {})[seg.a] = seg

    # ------------------------------------------------------------ look-ups
    def has_point(self, point_id: str) -> bool:
        """True for a vertiport or route-node id."""
        return point_id in self.vertiports or point_id in self.nodes

    def position(self, point_id: str) -> tuple[float, float]:
        """(lat, lon) [deg] of a vertiport or route node; KeyError if unknown."""
        v = self.vertiports.get(point_id)
        if v is not None:
            return v.lat, v.lon
        n = self.nodes[point_id]
        return n.lat, n.lon

    def segment(self, a: str, b: str) -> Segment | None:
        """The segment joining two points, or None."""
        return self._adjacency.get(a, {}).get(b)

    def neighbours(self, point_id: str) -> Iterable[str]:
        return self._adjacency.get(point_id, {}).keys()

    @cached_property
    def point_ids(self) -> list[str]:
        """Vertiports then route nodes, in file order (fixes scenario names)."""
        return [*self.vertiports, *self.nodes]

    # ------------------------------------------------------------ routes
    def route_lanes(self, path: Sequence[str]) -> tuple[float, ...]:
        """Lanes [ft] available on every segment of a path (lowest first).

        Raises:
            KeyError: two consecutive points are not joined by a segment.
        """
        lanes: set[float] | None = None
        for a, b in pairwise(path):
            seg = self.segment(a, b)
            if seg is None:
                raise KeyError(f"no segment between {a} and {b}")
            lanes = set(seg.lanes_ft) if lanes is None else lanes & set(seg.lanes_ft)
        return tuple(sorted(lanes or ()))

    def path_positions(self, path: Sequence[str]) -> list[tuple[float, float]]:
        """(lat, lon) [deg] of every point of a path."""
        return [self.position(p) for p in path]

    def path_length_m(self, path: Sequence[str]) -> float:
        """Length of a path [m] along WGS-84 geodesics between its points."""
        return sum(self.leg_length_m(a, b) for a, b in pairwise(path))

    def leg_length_m(self, a: str, b: str) -> float:
        """Geodesic distance between two points [m]."""
        (lat1, lon1), (lat2, lon2) = self.position(a), self.position(b)
        return geodesic_inverse(lat1, lon1, lat2, lon2)[1]

    def shortest_path(self, origin: str, destination: str) -> list[str] | None:
        """Shortest path (by geodesic length) from one vertiport to another, or None.

        The path starts with ``origin`` and ends with ``destination``; it never
        passes through a third vertiport. Ties are broken by point id so the
        result is deterministic.
        """
        if origin == destination:
            return [origin]
        best: dict[str, float] = {origin: 0.0}
        previous: dict[str, str] = {}
        heap: list[tuple[float, str]] = [(0.0, origin)]
        while heap:
            dist, here = heapq.heappop(heap)
            if here == destination:
                break
            if dist > best.get(here, math.inf):
                continue
            if here != origin and here in self.vertiports:
                continue  # vertiports end paths; they are not waypoints to fly through
            for nxt in sorted(self.neighbours(here)):
                cand = dist + self.leg_length_m(here, nxt)
                if cand < best.get(nxt, math.inf) - 1e-9:
                    best[nxt] = cand
                    previous[nxt] = here
                    heapq.heappush(heap, (cand, nxt))
        if destination not in previous:
            return None
        path = [destination]
        while path[-1] != origin:
            path.append(previous[path[-1]])
        return path[::-1]
