"""Closed parts of a floor: what a closure shuts, and the ways that stay open.

An operator closes a **segment** (a path), a **point**, or a **polygon** (an area in
layout coordinates) for maintenance or a spill. What is closed:

* a segment: that path;
* a point: that point and every path that ends at it (none can be driven without
  reaching the point);
* a polygon: every point it touches (inside or on its edge), every path whose line it
  touches, and every path that ends at one of those points.

:class:`OpenWays` routes over what stays open: no closed path is driven, no closed
point reached. A vehicle that stands on a closed point first leaves by the shortest
way out (over closed paths, to the nearest open point), then drives on over open
ways only. :func:`cut_off_stations` tells which stations a set of closures would cut
off from the rest of the floor.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import shapely

from agv_app.geometry import XY
from agv_app.layout.elements import LayoutError, NoRouteError, Route
from agv_app.layout.graph import Layout
from agv_app.layout.search import Arc, shortest_paths, strong_components

__all__ = [
    "CLOSURE_KINDS",
    "Closed",
    "ClosureKind",
    "OpenWays",
    "UnknownElement",
    "closed_by",
    "cut_off_stations",
    "known_list",
]

ClosureKind = Literal["segment", "point", "polygon"]
"""What an operator closes."""

CLOSURE_KINDS: tuple[ClosureKind, ...] = ("segment", "point", "polygon")
"""Every kind of closure, in a fixed order."""

_KNOWN_SHOWN = 10


class UnknownElement(LayoutError):
    """A closure names a point or segment the layout does not have.

    Attributes:
        kind: ``"point"`` or ``"segment"``.
        name: the unknown id.
        known: the known ids of that kind, sorted.
    """

    def __init__(self, kind: str, name: str, known: Sequence[str]) -> None:
        super().__init__(f"unknown {kind} {name!r} (known: {known_list(known)})")
        self.kind = kind
        self.name = name
        self.known = tuple(known)


def known_list(known: Sequence[str], limit: int = _KNOWN_SHOWN) -> str:
    """The first ``limit`` of ``known`` joined by commas, ``...`` if there are more."""
    head = ", ".join(known[:limit])
    return head + (", ..." if len(known) > limit else "")


@dataclass(frozen=True, slots=True)
class Closed:
    """The points and segments a closure (or several) shuts."""

    points: frozenset[str] = frozenset()
    segments: frozenset[str] = frozenset()

    def __or__(self, other: Closed) -> Closed:
        return Closed(self.points | other.points, self.segments | other.segments)

    @property
    def empty(self) -> bool:
        """True when nothing is closed."""
        return not self.points and not self.segments


def closed_by(layout: Layout, kind: ClosureKind, what: str | Sequence[XY]) -> Closed:
    """What closing ``what`` (a segment id, a point id or a polygon's vertices) shuts.

    Raises:
        UnknownElement: an unknown segment or point id.
        LayoutError: a polygon with fewer than three vertices, a non-finite or
            self-crossing one, or one that touches nothing of the layout.
    """
    if kind == "segment":
        if not isinstance(what, str) or what not in layout.segments:
            raise UnknownElement("segment", str(what), sorted(layout.segments))
        return Closed(segments=frozenset({what}))
    if kind == "point":
        if not isinstance(what, str) or what not in layout.points:
            raise UnknownElement("point", str(what), sorted(layout.points))
        return Closed(frozenset({what}), _ending_at(layout, {what}))
    if isinstance(what, str):
        raise LayoutError("a polygon is a list of [x, y] vertices")
    return _in_polygon(layout, what)


def _ending_at(layout: Layout, points: Collection[str]) -> frozenset[str]:
    return frozenset(
        sid for sid, seg in layout.segments.items() if seg.start in points or seg.end in points
    )


def _in_polygon(layout: Layout, vertices: Sequence[XY]) -> Closed:
    if len(vertices) < 3:
        raise LayoutError(f"a polygon needs at least 3 vertices, got {len(vertices)}")
    if not all(math.isfinite(c) for v in vertices for c in v):
        raise LayoutError("a polygon's vertices must be finite numbers")
    polygon = shapely.Polygon(vertices)
    if not polygon.is_valid or polygon.area <= 0.0:
        raise LayoutError("the polygon crosses itself or has no area")
    points = frozenset(
        pid for pid, p in layout.points.items() if polygon.intersects(shapely.Point(p.x, p.y))
    )
    crossed = frozenset(
        sid
        for sid in layout.segments
        if polygon.intersects(shapely.LineString(layout.segment_coords(sid)))
    )
    if not points and not crossed:
        raise LayoutError("the polygon touches no point and no path of the layout")
    return Closed(points, crossed | _ending_at(layout, points))


class OpenWays:
    """Routes and distances over the open part of a layout.

    Args:
        layout: the floor plan.
        closed: what is closed.
    """

    __slots__ = ("_cache", "_inside", "_open", "closed", "layout")

    def __init__(self, layout: Layout, closed: Closed) -> None:
        self.layout = layout
        self.closed = closed
        points, segments = closed.points, closed.segments
        # The ways out: every arc leaving a closed point (a vehicle there may drive out).
        self._inside: dict[str, list[Arc]] = {pid: [] for pid in layout.points}
        self._open: dict[str, list[Arc]] = {pid: [] for pid in layout.points}
        for pid in layout.points:
            for target in layout.successors(pid):
                sid = layout.segment_between(pid, target)
                assert sid is not None
                coords = layout.segment_coords(sid)
                if layout.segments[sid].start != pid:
                    coords = coords[::-1]
                arc = Arc(sid, target, layout.segment_length(sid), coords)
                if pid in points:
                    self._inside[pid].append(arc)
                if sid not in segments and target not in points and pid not in points:
                    self._open[pid].append(arc)
        self._cache: dict[str, tuple[dict[str, float], dict[str, tuple[str, str]]]] = {}

    def is_closed(self, point_id: str) -> bool:
        """True if the point ``point_id`` is closed."""
        return point_id in self.closed.points

    def _search(self, source: str) -> tuple[dict[str, float], dict[str, tuple[str, str]]]:
        found = self._cache.get(source)
        if found is None:
            found = self._cache[source] = shortest_paths(self._open, source)
        return found

    def distance(self, a: str, b: str) -> float:
        """Shortest open driving distance ``a -> b`` (``math.inf``: none); from a closed
        point by a way out."""
        if b in self.closed.points:
            return math.inf
        if a not in self.closed.points:
            return self._search(a)[0].get(b, math.inf)
        best = self._best_out(a, b)
        return math.inf if best is None else best[0]

    def _best_out(self, a: str, b: str) -> tuple[float, tuple[str, ...]] | None:
        """The shortest route from the closed point ``a`` to ``b``, out by the way that
        makes the whole route shortest: its length and points; None if there is none."""
        best: tuple[float, tuple[str, ...]] | None = None
        for out, exit_, way in self._exits(a):
            dist, prev = self._search(exit_)
            if b in dist and (best is None or out + dist[b] < best[0] - 1e-9):
                best = (out + dist[b], (*way[:-1], *_path(exit_, b, prev)))
        return best

    def _exits(self, a: str) -> list[tuple[float, str, tuple[str, ...]]]:
        """The open points next to the closed area around ``a``: ``(distance, point,
        way there)``, nearest first (ties: the lowest point id)."""
        dist, prev = shortest_paths(self._inside, a)
        exits = sorted((d, pid) for pid, d in dist.items() if pid not in self.closed.points)
        return [(d, pid, _path(a, pid, prev)) for d, pid in exits]

    def way_out(self, a: str) -> Route | None:
        """The shortest way from the closed point ``a`` to an open point (over closed
        paths), or None where there is none."""
        exits = self._exits(a)
        return self.layout.route_through(exits[0][2]) if exits else None

    def route(self, a: str, b: str) -> Route:
        """The shortest open route ``a -> b``; from a closed point ``a``, out of the
        closed area first, by the way out that makes the whole route shortest.

        Raises:
            NoRouteError: ``b`` is closed, or no open way leads there.
        """
        if b in self.closed.points:
            raise NoRouteError(f"point {b!r} is closed")
        if a not in self.closed.points:
            dist, prev = self._search(a)
            if b not in dist:
                raise NoRouteError(f"no open route from point {a!r} to point {b!r}")
            return self.layout.route_through(_path(a, b, prev))
        best = self._best_out(a, b)
        if best is None:
            raise NoRouteError(f"no open route from the closed point {a!r} to point {b!r}")
        return self.layout.route_through(best[1])

    def components(self) -> dict[str, int]:
        """The strongly connected component number of every point, over open ways."""
        return strong_components(self.layout.points, self._open)

    def blocking(self, a: str, b: str) -> tuple[str, ...]:
        """The closed points and paths on the shortest route ``a -> b`` of the whole
        layout (what keeps an order from going that way): ``point X`` then ``path P``,
        each sorted."""
        try:
            route = self.layout.route(a, b)
        except NoRouteError:
            return ()
        points = sorted(p for p in route.points if p in self.closed.points)
        segments = sorted(s for s in route.segments if s in self.closed.segments)
        return (*(f"point {p}" for p in points), *(f"path {s}" for s in segments))


def _path(a: str, b: str, prev: Mapping[str, tuple[str, str]]) -> tuple[str, ...]:
    path = [b]
    while path[-1] != a:
        path.append(prev[path[-1]][0])
    return tuple(reversed(path))


def cut_off_stations(ways: OpenWays, stations: Iterable[str] | None = None) -> tuple[str, ...]:
    """The stations (of ``stations``: default, the layout's usable ones) that the open
    ways cut off: a closed station point, or one outside the largest group of those
    stations that can still all reach each other. Sorted."""
    layout = ways.layout
    ids = sorted(layout.usable_stations() if stations is None else stations)
    comp = ways.components()
    groups: dict[int, list[str]] = {}
    for sid in ids:
        point = layout.station(sid).point
        if point not in ways.closed.points:
            groups.setdefault(comp[point], []).append(sid)
    best: list[str] = []
    for members in groups.values():
        if len(members) > len(best) or (len(members) == len(best) and members < best):
            best = members
    keep = set(best)
    return tuple(sid for sid in ids if sid not in keep)
