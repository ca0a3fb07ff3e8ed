"""The floor plan: an immutable graph of points, segments and stations.

A :class:`Layout` holds

* **points**: named positions in metres;
* **segments**: paths between two points, straight or bent through ``via``
  vertices (that is how arcs and curves are drawn), driven ``start -> end`` only,
  or both ways if ``bidirectional``;
* **stations**: where work happens (``pick``, ``drop``, ``pickdrop``) or where
  vehicles wait (``parking``, ``charging``), each at a point;
* **blocks**: named sets of element ids (points, segments, stations) kept from
  imported models for callers that want them; the layout does not interpret them.

Routing is Dijkstra over the directed graph with a deterministic tie-break (equal
distances are settled in point-id order), so every run picks the same route.

Passing places (deadlock avoidance, DESIGN.md "The AGV application"): two
vehicles meeting head-on on a bidirectional stretch can only get out of each
other's way where the stretch ends. A point is a **passing place** if

1. it has three or more distinct neighbouring points (a junction: one vehicle can
   turn into another branch), or
2. it has at most one neighbouring point (a dead end: nobody comes from beyond), or
3. it is marked ``passing=True`` (e.g. a widened lay-by the graph cannot show).

A station in the middle of a corridor is *not* a passing place: a vehicle waiting
there still blocks the corridor. :meth:`Layout.passing_extent` tells how far a
lock request on a bidirectional segment must reach.

The elements and errors are in :mod:`agv_app.layout.elements`; their checks and
lookups (:class:`~agv_app.layout.plan.FloorPlan`, which :class:`Layout` extends) in
:mod:`agv_app.layout.plan`; the graph searches in :mod:`agv_app.layout.search`.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Collection, Iterable, Mapping, Sequence
from types import MappingProxyType

from agv_app.geometry import XY, Polyline
from agv_app.layout.elements import (
    LayoutError,
    NoRouteError,
    PassingExtent,
    Point,
    Route,
    Segment,
    Station,
)
from agv_app.layout.plan import MAX_FLOOR_COORDINATE_M, FloorPlan
from agv_app.layout.search import shortest_paths, strong_components

__all__ = ["MAX_FLOOR_COORDINATE_M", "Layout"]


class Layout(FloorPlan):
    """An immutable, validated floor plan with routing queries.

    Args:
        points: all points.
        segments: all segments.
        stations: all stations.
        blocks: named sets of element ids (points, segments or stations).
        name: a label for messages and the dashboard.
        require_connected_stations: raise if some station cannot reach every
            other station (see :meth:`unreachable_stations`). Importers of
            foreign models may pass ``False`` and let callers use
            :meth:`usable_stations`.

    Raises:
        LayoutError: duplicate ids, an unknown point referenced, a non-finite
            coordinate, a zero-length segment, an unknown station kind or block
            member, two segments joining the same points in the same direction,
            or (by default) mutually unreachable stations.
    """

    __slots__ = ("_dist_cache", "_passing", "_usable")

    def __init__(
        self,
        points: Iterable[Point],
        segments: Iterable[Segment],
        stations: Iterable[Station] = (),
        *,
        blocks: Mapping[str, Iterable[str]] | None = None,
        name: str = "layout",
        require_connected_stations: bool = True,
    ) -> None:
        super().__init__(points, segments, stations, blocks=blocks, name=name)
        self._passing = frozenset(
            pid
            for pid, p in self._points.items()
            if p.passing or len(self._neighbours[pid]) >= 3 or len(self._neighbours[pid]) <= 1
        )
        self._dist_cache: dict[str, tuple[dict[str, float], dict[str, tuple[str, str]]]] = {}
        self._usable = self._largest_station_component()
        if require_connected_stations:
            bad = self.unreachable_stations()
            if bad:
                raise LayoutError(
                    "stations not mutually reachable: "
                    + ", ".join(repr(s) for s in bad)
                    + f" cannot reach or be reached from {self._usable[0]!r}"
                )

    # -- graph ------------------------------------------------------------------

    def neighbours(self, point_id: str) -> tuple[str, ...]:
        """Points joined to ``point_id`` by a segment in either direction, sorted."""
        self.point(point_id)
        return self._neighbours[point_id]

    def successors(self, point_id: str) -> tuple[str, ...]:
        """Points reachable from ``point_id`` over one segment, in the allowed direction."""
        self.point(point_id)
        return tuple(arc.target for arc in self._arcs[point_id])

    def segment_between(self, a: str, b: str) -> str | None:
        """Id of the segment drivable ``a -> b``, or None."""
        self.point(a)
        for arc in self._arcs[a]:
            if arc.target == b:
                return arc.segment
        return None

    def is_bidirectional(self, a: str, b: str) -> bool:
        """True if some segment joins ``a`` and ``b`` and may be driven both ways."""
        sid = self.segment_between(a, b) or self.segment_between(b, a)
        return sid is not None and self._segments[sid].bidirectional

    def _search(self, source: str) -> tuple[dict[str, float], dict[str, tuple[str, str]]]:
        cached = self._dist_cache.get(source)
        if cached is None:
            cached = self._dist_cache[source] = shortest_paths(self._arcs, source)
        return cached

    def distances_from(self, source: str) -> Mapping[str, float]:
        """Shortest driving distance from ``source`` to every reachable point (cached)."""
        self.point(source)
        return MappingProxyType(self._search(source)[0])

    def distance(self, a: str, b: str) -> float:
        """Shortest driving distance ``a -> b`` in metres; ``math.inf`` if unreachable."""
        self.point(b)
        return self.distances_from(a).get(b, math.inf)

    def shortest_path(self, a: str, b: str) -> tuple[str, ...]:
        """Point ids of the shortest route ``a -> b``, both ends included.

        Raises:
            LayoutError: unknown point.
            NoRouteError: ``b`` cannot be reached from ``a``.
        """
        self.point(a)
        self.point(b)
        return _path(a, b, *self._search(a))

    def route(self, a: str, b: str) -> Route:
        """The shortest route ``a -> b`` with its geometry (see :meth:`shortest_path`)."""
        return self.route_through(self.shortest_path(a, b))

    def route_avoiding(self, a: str, b: str, avoid: Collection[str]) -> Route:
        """The shortest route ``a -> b`` that drives none of the segments ``avoid``
        (not cached: a detour is rare).

        Raises:
            LayoutError: unknown point.
            NoRouteError: every route from ``a`` to ``b`` drives one of them.
        """
        self.point(a)
        self.point(b)
        arcs = {u: [x for x in out if x.segment not in avoid] for u, out in self._arcs.items()}
        return self.route_through(_path(a, b, *shortest_paths(arcs, a)))

    def route_through(self, points: Sequence[str]) -> Route:
        """Build a :class:`Route` along an explicit point sequence.

        Raises:
            LayoutError: empty sequence, unknown point, or two consecutive points
                not joined by a segment drivable in that direction.
        """
        if not points:
            raise LayoutError("a route needs at least one point")
        for p in points:
            self.point(p)
        coords: list[XY] = [self._points[points[0]].xy]
        segs: list[str] = []
        vertex_index = [0]
        for a, b in itertools.pairwise(points):
            arc = next((x for x in self._arcs[a] if x.target == b), None)
            if arc is None:
                raise LayoutError(f"no segment drivable from point {a!r} to point {b!r}")
            segs.append(arc.segment)
            coords.extend(arc.coords[1:])
            vertex_index.append(len(coords) - 1)
        poly = Polyline(coords)
        # Segments never repeat a vertex (checked on construction), so the polyline
        # keeps every vertex and its own arc lengths give the offsets exactly.
        offsets = tuple(poly.cumulative[k] for k in vertex_index)
        return Route(tuple(points), tuple(segs), poly, offsets)

    def route_length(self, points: Sequence[str]) -> float:
        """Length in metres of the route along ``points`` (see :meth:`route_through`)."""
        return self.route_through(points).length

    def route_polyline(self, points: Sequence[str]) -> tuple[XY, ...]:
        """Vertices ``(x, y)`` of the route along ``points`` (see :meth:`route_through`)."""
        return self.route_through(points).polyline.coords

    # -- passing places -----------------------------------------------------------

    def passing_places(self) -> frozenset[str]:
        """Ids of the points where vehicles can pass each other (rule in the module doc)."""
        return self._passing

    def is_passing_place(self, point_id: str) -> bool:
        """True if ``point_id`` is a passing place."""
        self.point(point_id)
        return point_id in self._passing

    def next_passing_place(self, route: Route, index: int) -> int | None:
        """Index of the first passing place on ``route`` strictly after ``index``, or None."""
        for i in range(index + 1, len(route.points)):
            if route.points[i] in self._passing:
                return i
        return None

    def passing_extent(self, route: Route, index: int) -> PassingExtent:
        """How far a lock request that enters segment ``index`` of ``route`` must reach.

        Segment ``index`` runs from ``route.points[index]`` to
        ``route.points[index + 1]``. If it is one-way, the request may stop at its
        end. If it is bidirectional, the request must cover the whole run of
        consecutive bidirectional segments up to the first passing place (or the
        route's end), so that a vehicle never stops where an oncoming one could
        meet it with no way round. The caller still adds half a hull length (and
        any margin) so the hull clears that point.

        Raises:
            LayoutError: ``index`` is not a segment index of ``route``.
        """
        if not 0 <= index < len(route.segments):
            raise LayoutError(
                f"segment index {index!r} outside route with {len(route.segments)} segments"
            )
        bidir = self._segments[route.segments[index]].bidirectional
        end = index + 1
        if bidir:
            while (
                end < len(route.segments)
                and route.points[end] not in self._passing
                and self._segments[route.segments[end]].bidirectional
            ):
                end += 1
        return PassingExtent(end, route.offsets[end], bidir)

    # -- station connectivity -------------------------------------------------------

    def _largest_station_component(self) -> tuple[str, ...]:
        """Stations in the largest mutually reachable group (ties: smallest ids first)."""
        comp = strong_components(self._points, self._arcs)
        groups: dict[int, list[str]] = {}
        for sid, st in self._stations.items():
            groups.setdefault(comp[st.point], []).append(sid)
        best: tuple[str, ...] = ()
        for ids in groups.values():
            cand = tuple(sorted(ids))
            if len(cand) > len(best) or (len(cand) == len(best) and cand < best):
                best = cand
        return best

    def usable_stations(self) -> tuple[str, ...]:
        """Ids of the largest set of stations that can all reach each other, sorted.

        A fleet can serve exactly these. Equal to all stations in a layout built
        with ``require_connected_stations=True``.
        """
        return self._usable

    def unreachable_stations(self) -> tuple[str, ...]:
        """Ids of stations outside :meth:`usable_stations`, sorted."""
        usable = set(self._usable)
        return tuple(sorted(s for s in self._stations if s not in usable))

    def __repr__(self) -> str:
        return (
            f"Layout({self._name!r}, {len(self._points)} points, {len(self._segments)} segments, "
            f"{len(self._stations)} stations)"
        )


def _path(
    a: str, b: str, dist: Mapping[str, float], prev: Mapping[str, tuple[str, str]]
) -> tuple[str, ...]:
    """The points of the shortest route ``a -> b`` from a search out of ``a``.

    Raises:
        NoRouteError: the search did not reach ``b``.
    """
    if b not in dist:
        raise NoRouteError(f"no route from point {a!r} to point {b!r}")
    path = [b]
    while path[-1] != a:
        path.append(prev[path[-1]][0])
    return tuple(reversed(path))
