"""Hulls and hull projections: the area a vehicle covers and sweeps.

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
"""

from __future__ import annotations

import bisect
import math
from typing import Any

import shapely

from agv_app.geometry.area import Area, Pose, Spine
from agv_app.geometry.polyline import Polyline

__all__ = ["hull", "hull_projection", "hull_projection_sampled", "projection_ahead"]


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


_HULLS: dict[tuple[float, float, float, float, float], Area] = {}
_HULLS_KEPT = 8192
"""Hulls remembered by pose and size: the safety monitor asks for every vehicle's hull at
every step, and most vehicles stand still. An ``Area`` is immutable, so one may be
handed out twice."""


def hull(pose: Pose, *, length: float, width: float) -> Area:
    """Return the vehicle rectangle at ``pose``, centred on its position.

    Args:
        pose: position and heading.
        length: extent along the heading, metres.
        width: extent across the heading, metres.
    """
    key = (pose.x, pose.y, pose.heading_rad, length, width)
    area = _HULLS.get(key)
    if area is None:
        if len(_HULLS) >= _HULLS_KEPT:
            _HULLS.clear()
        area = _HULLS[key] = Area(_rect(pose.x, pose.y, pose.heading_rad, length / 2, width / 2))
    return area


def _stretch(
    polyline: Polyline, start_s: float, end_s: float, *, length: float, width: float, step: float
) -> tuple[float, float, Area | None]:
    """Check a projection's arguments; its clamped ``(start, end)``, and the hull at
    rest when the polyline is a single point (then that is the whole projection)."""
    if not (length > 0 and width > 0):
        raise ValueError(f"hull needs a positive length and width, got {length!r} x {width!r}")
    if not step > 0:
        raise ValueError(f"step must be positive, got {step!r}")
    a, b = polyline.clamp(start_s), polyline.clamp(end_s)
    if b < a:
        raise ValueError(f"projection end {end_s!r} before start {start_s!r}")
    if len(polyline.coords) > 1:
        return a, b, None
    x, y = polyline.coords[0]
    half_l, half_w = length / 2, width / 2
    rest = _rect(x, y, polyline.rest_heading_rad, half_l, half_w)
    return a, b, Area(rest, Spine(shapely.Point(x, y), _clearance(half_l, half_w)))


def _clearance(half_l: float, half_w: float) -> float:
    """How far every point of a projection's path lies inside it: a hull centred on
    it (the disc of its shorter half side), less a hair for rounding."""
    return min(half_l, half_w) * (1.0 - 1e-9)


def _path(polyline: Polyline, a: float, b: float) -> Any:
    """The path driven from ``a`` to ``b``: a projection's spine."""
    pts = [polyline.point_at(a)]
    cums = polyline.cumulative
    pts.extend(polyline.coords[bisect.bisect_right(cums, a) : bisect.bisect_left(cums, b)])
    pts.append(polyline.point_at(b))
    if len(pts) == 2 and pts[0] == pts[1]:
        return shapely.Point(pts[0])
    return shapely.LineString(pts)


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
    a, b, at_rest = _stretch(polyline, start_s, end_s, length=length, width=width, step=step)
    if at_rest is not None:
        return at_rest
    half_l, half_w = length / 2, width / 2
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
    # Every point of the path is the centre of a hull the projection holds.
    spine = Spine(_path(polyline, a, b), _clearance(half_l, half_w))
    if len(shapes) == 1:
        return Area(shapes[0], spine)
    return Area(shapely.union_all(shapes), spine)


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
    a, b, at_rest = _stretch(polyline, start_s, end_s, length=length, width=width, step=step)
    if at_rest is not None:
        return at_rest
    half_l, half_w = length / 2, width / 2
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
