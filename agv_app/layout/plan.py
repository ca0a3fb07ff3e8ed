"""A floor plan's elements, checked and indexed: the data a layout routes over.

A :class:`FloorPlan` holds the points, segments, stations and blocks of a floor plan
(the elements are in :mod:`agv_app.layout.elements`), refuses inconsistent ones as it
is built, and answers lookups: an element by id, a segment's vertices and length, the
stations at a point or of a kind, the plan's bounds. It also keeps the directed arcs
and the neighbours of each point, for the graph queries of
:class:`~agv_app.layout.graph.Layout` (routing, passing places, station connectivity).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping
from types import MappingProxyType

from agv_app.geometry import XY, Polyline
from agv_app.layout.elements import (
    STATION_KINDS,
    LayoutError,
    Point,
    Segment,
    Station,
    StationKind,
)
from agv_app.layout.search import Arc

__all__ = ["MAX_FLOOR_COORDINATE_M", "FloorPlan"]

_MIN_SEGMENT_M = 1e-6

MAX_FLOOR_COORDINATE_M = 1e6
"""How far from the origin a point of a floor plan may lie, metres: a plant in millimetres
read as metres still fits, and a position beyond it is a mistake, not a floor."""


def _on_floor(x: float, y: float) -> bool:
    return abs(x) <= MAX_FLOOR_COORDINATE_M and abs(y) <= MAX_FLOOR_COORDINATE_M


class FloorPlan:
    """An immutable, validated set of floor plan elements with their lookups.

    Args:
        points: all points.
        segments: all segments.
        stations: all stations.
        blocks: named sets of element ids (points, segments or stations).
        name: a label for messages and the dashboard.

    Raises:
        LayoutError: duplicate ids, an unknown point referenced, a non-finite
            coordinate, a zero-length segment, an unknown station kind or block
            member, or two segments joining the same points in the same direction.
    """

    __slots__ = (
        "_arcs",
        "_blocks",
        "_name",
        "_neighbours",
        "_points",
        "_segment_coords",
        "_segment_length",
        "_segments",
        "_stations",
        "_stations_at",
    )

    def __init__(
        self,
        points: Iterable[Point],
        segments: Iterable[Segment],
        stations: Iterable[Station] = (),
        *,
        blocks: Mapping[str, Iterable[str]] | None = None,
        name: str = "layout",
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


def _by_id(s: Station) -> str:
    return s.id
