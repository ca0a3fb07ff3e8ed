"""Floor geometry: polylines, AGV hulls, hull projections and their wire form.

Everything is in metres and radians on the floor plane. A vehicle's *hull* is the
rectangle it covers, centred on its reference position and aligned with its
heading. A *hull projection* is the area the hull sweeps while the vehicle drives
a stretch of its route (DESIGN.md, "The AGV application").

Heading follows the direction of the straight piece being driven, so it changes
only at polyline vertices, where the vehicle turns on the spot. A projection
therefore consists of

* one rectangle per straight piece: a rectangle moving straight sweeps exactly a
  longer rectangle, so no sampling is needed there, and
* at each turn, the area the hull sweeps while rotating on the spot from the
  incoming to the outgoing heading: the hull at the incoming heading plus the
  four circular sectors its corners trace (arcs drawn with vertices at most
  ``step`` metres apart, circumscribed so they never fall short).

``hull_projection_sampled`` is the definition written out naively (a hull every
``step`` metres along the path, and rotated copies every ``step`` metres of
corner travel at turns); ``hull_projection`` builds a slightly larger area (it
fills the slivers between the sampled copies) from a handful of shapes and is
what the fleet should call.

shapely has no type stubs, so shapely objects travel inside :class:`Area`.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

__all__ = [
    "DEFAULT_OVERLAP_TOLERANCE_M2",
    "WIRE_MARGIN_M",
    "XY",
    "Area",
    "Polyline",
    "Pose",
    "coords_to_polygon",
    "hull",
    "hull_length",
    "hull_projection",
    "hull_projection_sampled",
    "overlaps",
    "polygon_to_coords",
    "projection_ahead",
]

XY = tuple[float, float]
"""A point on the floor, ``(x, y)`` in metres."""

DEFAULT_OVERLAP_TOLERANCE_M2 = 1e-6
"""Intersections smaller than this (1 mm²) do not count as an overlap."""

WIRE_MARGIN_M = 0.02
"""How far :func:`polygon_to_coords` grows a shape so that rounding never shrinks it."""

_EPS = 1e-12


@dataclass(frozen=True, slots=True)
class Pose:
    """Where a vehicle stands: position in metres and heading in radians (0 = +x)."""

    x: float
    y: float
    heading_rad: float


class Area:
    """An immutable area on the floor (a shapely polygon or multipolygon, maybe empty).

    The raw shapely object is available as :attr:`geom` for callers that need
    more than the methods here; do not mutate it.
    """

    __slots__ = ("geom",)

    geom: Any

    def __init__(self, geom: Any) -> None:
        """Wrap a shapely geometry (use :meth:`empty` for nothing)."""
        object.__setattr__(self, "geom", geom)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("Area is immutable")

    def __repr__(self) -> str:
        return f"Area({self.geom.wkt if not self.is_empty else 'EMPTY'})"

    @classmethod
    def empty(cls) -> Area:
        """Return the empty area."""
        return cls(shapely.Polygon())

    @classmethod
    def union_of(cls, areas: Iterable[Area]) -> Area:
        """Return the union of ``areas`` (empty if there are none)."""
        geoms = [a.geom for a in areas if not a.is_empty]
        if not geoms:
            return cls.empty()
        return cls(shapely.union_all(geoms))

    @property
    def is_empty(self) -> bool:
        """True if the area covers nothing."""
        return bool(self.geom.is_empty)

    @property
    def area_m2(self) -> float:
        """Size in square metres."""
        return float(self.geom.area)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(min_x, min_y, max_x, max_y)``; all NaN when empty."""
        b = self.geom.bounds
        return (float(b[0]), float(b[1]), float(b[2]), float(b[3]))

    def union(self, other: Area) -> Area:
        """Return the union of the two areas."""
        return Area(self.geom.union(other.geom))

    def intersection(self, other: Area) -> Area:
        """Return the common part of the two areas."""
        return Area(self.geom.intersection(other.geom))

    def difference(self, other: Area) -> Area:
        """Return this area minus ``other``."""
        return Area(self.geom.difference(other.geom))

    def buffer(self, distance_m: float) -> Area:
        """Return the area grown (or shrunk, if negative) by ``distance_m``, mitred corners."""
        return Area(self.geom.buffer(distance_m, join_style="mitre"))

    def contains(self, other: Area, *, tolerance_m: float = 1e-9) -> bool:
        """True if ``other`` lies inside this area grown by ``tolerance_m``."""
        if other.is_empty:
            return True
        return bool(self.geom.buffer(tolerance_m, join_style="mitre").contains(other.geom))

    def contains_point(self, xy: XY) -> bool:
        """True if the point lies inside or on the boundary."""
        return bool(self.geom.covers(shapely.Point(xy)))

    def distance_to(self, xy: XY) -> float:
        """Shortest distance from the point to the area (0 inside)."""
        return float(self.geom.distance(shapely.Point(xy)))

    def overlaps(self, other: Area, *, tolerance_m2: float = DEFAULT_OVERLAP_TOLERANCE_M2) -> bool:
        """True if the areas share more than ``tolerance_m2`` m² (see :func:`overlaps`)."""
        return overlaps(self, other, tolerance_m2=tolerance_m2)


@dataclass(frozen=True, slots=True, init=False)
class Polyline:
    """A path of straight pieces with cumulative arc lengths.

    Consecutive duplicate vertices are dropped on construction, so every piece has
    a positive length. A polyline with a single vertex has length 0; its heading
    is the ``heading_rad`` given at construction (default 0).

    Attributes:
        coords: the vertices.
        cumulative: arc length at each vertex (``cumulative[0] == 0``).
    """

    coords: tuple[XY, ...]
    cumulative: tuple[float, ...]
    rest_heading_rad: float

    def __init__(self, coords: Iterable[XY], *, heading_rad: float = 0.0) -> None:
        """Build from at least one vertex.

        Args:
            coords: vertices in driving order.
            heading_rad: heading reported by a polyline of length 0.

        Raises:
            ValueError: no vertex, or a non-finite coordinate.
        """
        pts: list[XY] = []
        for x, y in coords:
            fx, fy = float(x), float(y)
            if not (math.isfinite(fx) and math.isfinite(fy)):
                raise ValueError(f"non-finite polyline vertex {(x, y)!r}")
            if pts and math.hypot(fx - pts[-1][0], fy - pts[-1][1]) <= _EPS:
                continue
            pts.append((fx, fy))
        if not pts:
            raise ValueError("a polyline needs at least one vertex")
        cum = [0.0]
        for (x0, y0), (x1, y1) in itertools.pairwise(pts):
            cum.append(cum[-1] + math.hypot(x1 - x0, y1 - y0))
        object.__setattr__(self, "coords", tuple(pts))
        object.__setattr__(self, "cumulative", tuple(cum))
        object.__setattr__(self, "rest_heading_rad", float(heading_rad))

    @property
    def length(self) -> float:
        """Total arc length in metres."""
        return self.cumulative[-1]

    @property
    def start(self) -> XY:
        """First vertex."""
        return self.coords[0]

    @property
    def end(self) -> XY:
        """Last vertex."""
        return self.coords[-1]

    def clamp(self, s: float) -> float:
        """Return ``s`` limited to ``[0, length]``."""
        return min(max(s, 0.0), self.length)

    def piece_index(self, s: float) -> int:
        """Index ``i`` of the piece ``coords[i] -> coords[i+1]`` that is driven at ``s``.

        A vehicle standing on a vertex still faces the piece it arrived on (it turns
        when it moves on), so at a vertex the *incoming* piece counts; at ``s == 0``
        it is piece 0. Returns 0 for a polyline of length 0.
        """
        n = len(self.coords) - 1
        if n == 0:
            return 0
        i = bisect.bisect_left(self.cumulative, self.clamp(s)) - 1
        return min(max(i, 0), n - 1)

    def point_at(self, s: float) -> XY:
        """Position at arc length ``s`` (clamped to the polyline)."""
        if len(self.coords) == 1:
            return self.coords[0]
        s = self.clamp(s)
        i = self.piece_index(s)
        (x0, y0), (x1, y1) = self.coords[i], self.coords[i + 1]
        s0, s1 = self.cumulative[i], self.cumulative[i + 1]
        t = (s - s0) / (s1 - s0)
        if t >= 1.0:
            return (x1, y1)
        return (x0 + (x1 - x0) * t, y0 + (y1 - y0) * t)

    def heading_at(self, s: float) -> float:
        """Heading in radians of the piece driven at ``s`` (see :meth:`piece_index`)."""
        if len(self.coords) == 1:
            return self.rest_heading_rad
        return self.piece_heading(self.piece_index(s))

    def pose_at(self, s: float) -> Pose:
        """Position and heading at arc length ``s``."""
        x, y = self.point_at(s)
        return Pose(x, y, self.heading_at(s))

    def slice(self, s0: float, s1: float) -> Polyline:
        """Return the part between arc lengths ``s0 <= s1`` (both clamped)."""
        s0, s1 = self.clamp(s0), self.clamp(s1)
        if s1 < s0:
            raise ValueError(f"slice end {s1!r} before start {s0!r}")
        pts = [self.point_at(s0)]
        lo = bisect.bisect_right(self.cumulative, s0)
        hi = bisect.bisect_left(self.cumulative, s1)
        pts.extend(self.coords[lo:hi])
        pts.append(self.point_at(s1))
        return Polyline(pts, heading_rad=self.heading_at(s0))

    def vertex_arclengths(self) -> tuple[float, ...]:
        """Arc lengths of the interior vertices, where the heading changes."""
        return self.cumulative[1:-1]

    def piece_heading(self, i: int) -> float:
        """Heading in radians of piece ``i`` (``coords[i] -> coords[i+1]``)."""
        (x0, y0), (x1, y1) = self.coords[i], self.coords[i + 1]
        return math.atan2(y1 - y0, x1 - x0)


def _rect(cx: float, cy: float, heading: float, half_l: float, half_w: float) -> Any:
    c, s = math.cos(heading), math.sin(heading)
    lx, ly = c * half_l, s * half_l
    wx, wy = -s * half_w, c * half_w
    return shapely.Polygon(
        [
            (cx + lx + wx, cy + ly + wy),
            (cx - lx + wx, cy - ly + wy),
            (cx - lx - wx, cy - ly - wy),
            (cx + lx - wx, cy + ly - wy),
        ]
    )


def hull(pose: Pose, *, length: float, width: float) -> Area:
    """Return the vehicle rectangle at ``pose``, centred on its position.

    Args:
        pose: position and heading.
        length: extent along the heading, metres.
        width: extent across the heading, metres.
    """
    return Area(_rect(pose.x, pose.y, pose.heading_rad, length / 2, width / 2))


def _check_dims(length: float, width: float, step: float) -> None:
    if not (length > 0 and width > 0):
        raise ValueError(f"hull needs a positive length and width, got {length!r} x {width!r}")
    if not step > 0:
        raise ValueError(f"step must be positive, got {step!r}")


def hull_projection(
    polyline: Polyline,
    start_s: float,
    end_s: float,
    *,
    length: float,
    width: float,
    step: float = 0.25,
) -> Area:
    """Return the area the hull sweeps while driving ``polyline`` from ``start_s`` to ``end_s``.

    Both ends are clamped to the polyline. The hull at ``start_s`` and at ``end_s``
    is included. A vehicle turns on a vertex when it drives on, so the turn at a
    vertex ``v`` belongs to the stretch iff ``start_s <= s_v < end_s``: a stretch
    that ends on a vertex leaves the hull facing the incoming piece.

    Args:
        polyline: the route.
        start_s: arc length where the stretch begins.
        end_s: arc length where it ends (``>= start_s``).
        length: hull length, metres.
        width: hull width, metres.
        step: largest distance, metres, any hull point moves between two copies
            of the hull at a turn.

    Returns:
        The swept area, a single polygon for a connected stretch.

    Raises:
        ValueError: ``end_s < start_s`` or a non-positive dimension or step.
    """
    _check_dims(length, width, step)
    a, b = polyline.clamp(start_s), polyline.clamp(end_s)
    if b < a:
        raise ValueError(f"projection end {end_s!r} before start {start_s!r}")
    half_l, half_w = length / 2, width / 2
    if len(polyline.coords) == 1:
        x, y = polyline.coords[0]
        return Area(_rect(x, y, polyline.rest_heading_rad, half_l, half_w))
    shapes: list[Any] = []
    first, last = polyline.piece_index(a), polyline.piece_index(b)
    i = first
    while i <= last:
        h = polyline.piece_heading(i)
        j = i
        # Collinear pieces (lanes split at every junction) make one straight run.
        while j < last and polyline.piece_heading(j + 1) == h:
            j += 1
        lo = max(a, polyline.cumulative[i])
        hi = min(b, polyline.cumulative[j + 1])
        (px, py), (qx, qy) = polyline.point_at(lo), polyline.point_at(hi)
        # A rectangle pushed straight sweeps a rectangle: the hull stretched by the
        # distance driven, centred between the first and last position.
        half_span = (hi - lo) / 2 + half_l
        shapes.append(_rect((px + qx) / 2, (py + qy) / 2, h, half_span, half_w))
        i = j + 1
    shapes.extend(_turn_shapes(polyline, a, b, half_l=half_l, half_w=half_w, step=step))
    if len(shapes) == 1:
        return Area(shapes[0])
    return Area(shapely.union_all(shapes))


def _turn_shapes(
    polyline: Polyline, a: float, b: float, *, half_l: float, half_w: float, step: float
) -> list[Any]:
    """Exact sweep of the turns made on ``[a, b]``: at vertices with ``a <= s_v < b``.

    A centred rectangle rotating from ``h0`` to ``h1`` sweeps exactly the union of
    the rectangles at ``h0`` and ``h1`` and the four circular sectors traced by its
    corners: in any fixed direction the distance to an edge, as a function of the
    angle, has no interior maximum between two corner crossings. The arcs are
    drawn circumscribed, so the result never falls short of the true sweep.
    """
    shapes: list[Any] = []
    cums = polyline.cumulative
    radius = math.hypot(half_l, half_w)
    corners = [
        math.atan2(sy * half_w, sx * half_l) for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))
    ]
    lo = bisect.bisect_left(cums, a, 1, len(cums) - 1)
    for v in range(lo, len(cums) - 1):
        if cums[v] >= b:
            break
        h_in, h_out = polyline.piece_heading(v - 1), polyline.piece_heading(v)
        delta = math.remainder(h_out - h_in, math.tau)
        if abs(delta) <= 1e-12:
            continue
        x, y = polyline.coords[v]
        shapes.append(_rect(x, y, h_in, half_l, half_w))
        n = max(1, math.ceil(abs(delta) * radius / step))
        d = delta / n
        r_out = radius / math.cos(d / 2)
        for c in corners:
            a0 = h_in + c
            ring = [(x, y), (x + radius * math.cos(a0), y + radius * math.sin(a0))]
            for k in range(n):
                ang = a0 + d * (k + 0.5)
                ring.append((x + r_out * math.cos(ang), y + r_out * math.sin(ang)))
            a1 = a0 + delta
            ring.append((x + radius * math.cos(a1), y + radius * math.sin(a1)))
            shapes.append(shapely.Polygon(ring))
    return shapes


def _turn_copies(
    polyline: Polyline, a: float, b: float, *, half_l: float, half_w: float, step: float
) -> list[Any]:
    """Hull copies rotated in steps at the turns on ``[a, b]`` (the naive reference)."""
    shapes: list[Any] = []
    cums = polyline.cumulative
    radius = math.hypot(half_l, half_w)
    for v in range(1, len(cums) - 1):
        if not a <= cums[v] < b:
            continue
        h_in, h_out = polyline.piece_heading(v - 1), polyline.piece_heading(v)
        delta = math.remainder(h_out - h_in, math.tau)
        n = max(1, math.ceil(abs(delta) * radius / step))
        x, y = polyline.coords[v]
        for k in range(n + 1):
            shapes.append(_rect(x, y, h_in + delta * k / n, half_l, half_w))
    return shapes


def hull_projection_sampled(
    polyline: Polyline,
    start_s: float,
    end_s: float,
    *,
    length: float,
    width: float,
    step: float = 0.25,
) -> Area:
    """The naive definition of :func:`hull_projection`: a hull every ``step`` metres.

    Slow; kept as the reference the fast version is tested against. Same
    arguments and result (up to floating-point noise) as :func:`hull_projection`.
    """
    _check_dims(length, width, step)
    a, b = polyline.clamp(start_s), polyline.clamp(end_s)
    if b < a:
        raise ValueError(f"projection end {end_s!r} before start {start_s!r}")
    half_l, half_w = length / 2, width / 2
    if len(polyline.coords) == 1:
        x, y = polyline.coords[0]
        return Area(_rect(x, y, polyline.rest_heading_rad, half_l, half_w))
    shapes: list[Any] = []
    for i in range(polyline.piece_index(a), polyline.piece_index(b) + 1):
        lo = max(a, polyline.cumulative[i])
        hi = min(b, polyline.cumulative[i + 1])
        h = polyline.piece_heading(i)
        n = max(1, math.ceil((hi - lo) / step))
        for k in range(n + 1):
            x, y = polyline.point_at(lo + (hi - lo) * k / n)
            shapes.append(_rect(x, y, h, half_l, half_w))
    shapes.extend(_turn_copies(polyline, a, b, half_l=half_l, half_w=half_w, step=step))
    return Area(shapely.union_all(shapes))


def projection_ahead(
    polyline: Polyline,
    s_now: float,
    end_s: float,
    *,
    length: float,
    width: float,
    step: float = 0.25,
) -> Area:
    """Return what remains of a projection once the vehicle has reached ``s_now``.

    This is the release operation: the part already driven over is cut away,
    leaving the hull at ``s_now`` and everything ahead of it up to ``end_s``. The
    result lies inside the projection of any earlier start on the same polyline
    with the same end (it is built from sub-rectangles of the same pieces), so a
    lock can shrink to it without ever losing area the vehicle still needs.
    """
    return hull_projection(
        polyline, s_now, max(s_now, end_s), length=length, width=width, step=step
    )


def hull_length(position: XY, shapes: Iterable[Area]) -> float:
    """Distance from ``position`` to the furthest point of ``shapes``; 0 if there are none.

    The furthest point of a polygon is one of its vertices, so only vertices are
    measured.
    """
    geoms = [a.geom for a in shapes if not a.is_empty]
    if not geoms:
        return 0.0
    xy = shapely.get_coordinates(geoms)
    if len(xy) == 0:
        return 0.0
    d = np.hypot(xy[:, 0] - position[0], xy[:, 1] - position[1])
    return float(d.max())


def overlaps(a: Area, b: Area, *, tolerance_m2: float = DEFAULT_OVERLAP_TOLERANCE_M2) -> bool:
    """True if the interiors of ``a`` and ``b`` share more than ``tolerance_m2`` square metres.

    Touching edges or corners is not an overlap: two hulls parked bumper to bumper
    are safe, and the tolerance keeps floating-point slivers from raising false
    alarms. Any real encroachment (1 mm x 1 m is already 10x the default) counts.
    """
    ga, gb = a.geom, b.geom
    if ga.is_empty or gb.is_empty:
        return False
    ax0, ay0, ax1, ay1 = ga.bounds
    bx0, by0, bx1, by1 = gb.bounds
    if ax1 < bx0 or bx1 < ax0 or ay1 < by0 or by1 < ay0:
        return False
    if not shapely.intersects(ga, gb):
        return False
    return float(shapely.intersection(ga, gb).area) > tolerance_m2


Coords = list[list[list[float]]]
"""Wire form of an area: polygons -> rings (exterior first) -> flat ``[x0, y0, x1, y1, ...]``."""


def polygon_to_coords(area: Area, *, margin_m: float = WIRE_MARGIN_M) -> Coords:
    """Encode ``area`` compactly for messages and the dashboard, rounded to centimetres.

    Rings are flat ``[x0, y0, x1, y1, ...]`` lists without the closing vertex. The
    area is first grown by ``margin_m`` (mitred, so corners stay corners) and
    lightly simplified, so that the decoded polygon always *contains* the original
    despite rounding: a receiver may over-estimate someone's area, never
    under-estimate it. Pass ``margin_m=0`` for display-only shapes.
    """
    if area.is_empty:
        return []
    geom = area.geom
    if margin_m > 0:
        geom = geom.buffer(margin_m, join_style="mitre").simplify(margin_m / 4)
    parts = list(geom.geoms) if geom.geom_type == "MultiPolygon" else [geom]
    out: Coords = []
    for poly in parts:
        if poly.is_empty:
            continue
        rings = [poly.exterior, *poly.interiors]
        out.append([_ring_flat(r) for r in rings])
    return out


def _ring_flat(ring: Any) -> list[float]:
    flat: list[float] = []
    pts = list(ring.coords)[:-1]
    prev: tuple[float, float] | None = None
    for x, y in pts:
        q = (round(float(x), 2), round(float(y), 2))
        if q == prev:
            continue
        flat.extend(q)
        prev = q
    if len(flat) > 2 and (flat[0], flat[1]) == (flat[-2], flat[-1]):
        del flat[-2:]
    return flat


def coords_to_polygon(coords: Sequence[Sequence[Sequence[float]]]) -> Area:
    """Decode the output of :func:`polygon_to_coords`.

    Raises:
        ValueError: a ring with an odd number of values or fewer than 3 vertices.
    """
    polys: list[Any] = []
    for p_index, rings in enumerate(coords):
        parsed: list[list[XY]] = []
        for r_index, flat in enumerate(rings):
            if len(flat) % 2 or len(flat) < 6:
                raise ValueError(
                    f"polygon {p_index} ring {r_index}: need an even number of at least "
                    f"6 values, got {len(flat)}"
                )
            parsed.append([(float(flat[k]), float(flat[k + 1])) for k in range(0, len(flat), 2)])
        if parsed:
            polys.append(shapely.Polygon(parsed[0], parsed[1:]))
    if not polys:
        return Area.empty()
    if len(polys) == 1:
        return Area(polys[0])
    return Area(shapely.MultiPolygon(polys))
