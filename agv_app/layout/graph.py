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

The elements and errors are in :mod:`agv_app.layout.elements`; the graph searches in
:mod:`agv_app.layout.search`.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Collection, Iterable, Mapping, Sequence
from types import MappingProxyType

from agv_app.geometry import XY, Polyline
from agv_app.layout.elements import (
    STATION_KINDS,
    LayoutError,
    NoRouteError,
    PassingExtent,
    Point,
    Route,
    Segment,
    Station,
    StationKind,
)
from agv_app.layout.search import Arc, shortest_paths, strong_components

__all__ = ["MAX_FLOOR_COORDINATE_M", "Layout"]


_MIN_SEGMENT_M = 1e-6

MAX_FLOOR_COORDINATE_M = 1e6
"""How far from the origin a point of a floor plan may lie, metres: a plant in millimetres
read as metres still fits, and a position beyond it is a mistake, not a floor."""


def _on_floor(x: float, y: float) -> bool:
    return abs(x) <= MAX_FLOOR_COORDINATE_M and abs(y) <= MAX_FLOOR_COORDINATE_M


class Layout:
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

    __slots__ = (
        "_arcs",
        "_blocks",
        "_dist_cache",
        "_name",
        "_neighbours",
        "_passing",
        "_points",
        "_segment_coords",
        "_segment_length",
        "_segments",
        "_stations",
        "_stations_at",
        "_usable",
    )

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
        self._name = name
        self._points: dict[str, Point] = {}
        for p in points:
            if p.id in self._points:
                raise LayoutError(f"duplicate point id {p.id!r}")
            if not (math.isfinite(p.x) and math.isfinite(p.y)):
                raise LayoutError(f"point {p.id!r}: non-finite position {(p.x, p.y)!r}")
            if not _on_floor(p.x, p.y):
                raise LayoutError(
                    f"point {p.id!r}: position {(p.x, p.y)!r} lies beyond "
                    f"+-{MAX_FLOOR_COORDINATE_M:g} m"
                )
            self._points[p.id] = p
        self._segments: dict[str, Segment] = {}
        self._segment_coords: dict[str, tuple[XY, ...]] = {}
        self._segment_length: dict[str, float] = {}
        self._arcs: dict[str, list[Arc]] = {pid: [] for pid in self._points}
        joined: dict[tuple[str, str], str] = {}
        for seg in segments:
            self._add_segment(seg, joined)
        for pid in self._arcs:
            self._arcs[pid].sort(key=lambda arc: (arc.target, arc.segment))
        self._neighbours: dict[str, tuple[str, ...]] = {}
        undirected: dict[str, set[str]] = {pid: set() for pid in self._points}
        for seg in self._segments.values():
            undirected[seg.start].add(seg.end)
            undirected[seg.end].add(seg.start)
        for pid, ns in undirected.items():
            self._neighbours[pid] = tuple(sorted(ns))
        self._passing = frozenset(
            pid
            for pid, p in self._points.items()
            if p.passing or len(undirected[pid]) >= 3 or len(undirected[pid]) <= 1
        )
        self._stations: dict[str, Station] = {}
        stations_at: dict[str, list[str]] = {}
        for st in stations:
            if st.id in self._stations:
                raise LayoutError(f"duplicate station id {st.id!r}")
            if st.point not in self._points:
                raise LayoutError(f"station {st.id!r}: unknown point {st.point!r}")
            if st.kind not in STATION_KINDS:
                raise LayoutError(
                    f"station {st.id!r}: unknown kind {st.kind!r} "
                    f"(expected one of {', '.join(STATION_KINDS)})"
                )
            self._stations[st.id] = st
            stations_at.setdefault(st.point, []).append(st.id)
        self._stations_at = {pid: tuple(sorted(ids)) for pid, ids in stations_at.items()}
        self._blocks: dict[str, frozenset[str]] = {}
        for bname, members in (blocks or {}).items():
            ms = frozenset(members)
            for m in sorted(ms):
                if m not in self._points and m not in self._segments and m not in self._stations:
                    raise LayoutError(f"block {bname!r}: unknown member {m!r}")
            self._blocks[bname] = ms
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

    def _add_segment(self, seg: Segment, joined: dict[tuple[str, str], str]) -> None:
        if seg.id in self._segments:
            raise LayoutError(f"duplicate segment id {seg.id!r}")
        for pid in (seg.start, seg.end):
            if pid not in self._points:
                raise LayoutError(f"segment {seg.id!r}: unknown end point {pid!r}")
        if seg.start == seg.end:
            raise LayoutError(f"segment {seg.id!r}: starts and ends at point {seg.start!r}")
        for v in seg.via:
            if not (math.isfinite(v[0]) and math.isfinite(v[1])):
                raise LayoutError(f"segment {seg.id!r}: non-finite via vertex {v!r}")
            if not _on_floor(*v):
                raise LayoutError(
                    f"segment {seg.id!r}: via vertex {v!r} lies beyond "
                    f"+-{MAX_FLOOR_COORDINATE_M:g} m"
                )
        coords = (self._points[seg.start].xy, *seg.via, self._points[seg.end].xy)
        for k, ((x0, y0), (x1, y1)) in enumerate(itertools.pairwise(coords)):
            if math.hypot(x1 - x0, y1 - y0) < _MIN_SEGMENT_M:
                if len(coords) == 2:
                    raise LayoutError(
                        f"segment {seg.id!r}: zero length "
                        f"(points {seg.start!r} and {seg.end!r} coincide)"
                    )
                raise LayoutError(f"segment {seg.id!r}: zero-length piece {k} (repeated vertex)")
        length = Polyline(coords).length
        directions = [(seg.start, seg.end)]
        if seg.bidirectional:
            directions.append((seg.end, seg.start))
        for a, b in directions:
            if (a, b) in joined:
                raise LayoutError(
                    f"segment {seg.id!r}: {a!r} -> {b!r} is already served by "
                    f"segment {joined[(a, b)]!r}"
                )
            joined[(a, b)] = seg.id
        self._segments[seg.id] = seg
        self._segment_coords[seg.id] = coords
        self._segment_length[seg.id] = length
        self._arcs[seg.start].append(Arc(seg.id, seg.end, length, coords))
        if seg.bidirectional:
            self._arcs[seg.end].append(Arc(seg.id, seg.start, length, coords[::-1]))

    # -- elements ---------------------------------------------------------------

    @property
    def name(self) -> str:
        """A label for messages and the dashboard."""
        return self._name

    @property
    def points(self) -> Mapping[str, Point]:
        """All points by id (insertion order)."""
        return MappingProxyType(self._points)

    @property
    def segments(self) -> Mapping[str, Segment]:
        """All segments by id (insertion order)."""
        return MappingProxyType(self._segments)

    @property
    def stations(self) -> Mapping[str, Station]:
        """All stations by id (insertion order)."""
        return MappingProxyType(self._stations)

    @property
    def blocks(self) -> Mapping[str, frozenset[str]]:
        """Named sets of element ids, as given (e.g. openTCS blocks)."""
        return MappingProxyType(self._blocks)

    def point(self, point_id: str) -> Point:
        """Return a point by id.

        Raises:
            LayoutError: unknown id.
        """
        try:
            return self._points[point_id]
        except KeyError:
            raise LayoutError(f"unknown point {point_id!r}") from None

    def station(self, station_id: str) -> Station:
        """Return a station by id.

        Raises:
            LayoutError: unknown id.
        """
        try:
            return self._stations[station_id]
        except KeyError:
            raise LayoutError(f"unknown station {station_id!r}") from None

    def segment(self, segment_id: str) -> Segment:
        """Return a segment by id.

        Raises:
            LayoutError: unknown id.
        """
        try:
            return self._segments[segment_id]
        except KeyError:
            raise LayoutError(f"unknown segment {segment_id!r}") from None

    def segment_length(self, segment_id: str) -> float:
        """Length of a segment in metres, ``via`` vertices included."""
        self.segment(segment_id)
        return self._segment_length[segment_id]

    def segment_coords(self, segment_id: str) -> tuple[XY, ...]:
        """Vertices of a segment from ``start`` to ``end``, ``via`` included."""
        self.segment(segment_id)
        return self._segment_coords[segment_id]

    def stations_of_kind(self, *kinds: StationKind) -> tuple[Station, ...]:
        """Stations of the given kinds, sorted by id."""
        return tuple(sorted((s for s in self._stations.values() if s.kind in kinds), key=_by_id))

    def stations_at(self, point_id: str) -> tuple[str, ...]:
        """Ids of the stations at a point, sorted (empty if none)."""
        self.point(point_id)
        return self._stations_at.get(point_id, ())

    def bounds(self) -> tuple[float, float, float, float]:
        """``(min_x, min_y, max_x, max_y)`` over points and ``via`` vertices.

        Raises:
            LayoutError: the layout has no points.
        """
        xs: list[float] = []
        ys: list[float] = []
        for p in self._points.values():
            xs.append(p.x)
            ys.append(p.y)
        for seg in self._segments.values():
            for x, y in seg.via:
                xs.append(x)
                ys.append(y)
        if not xs:
            raise LayoutError(f"layout {self._name!r} has no points")
        return (min(xs), min(ys), max(xs), max(ys))

    def diagonal(self) -> float:
        """The diagonal of ``bounds``: no two points of the layout lie farther apart."""
        x0, y0, x1, y1 = self.bounds()
        return math.hypot(x1 - x0, y1 - y0)

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


def _by_id(s: Station) -> str:
    return s.id


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
