"""The wire form of an area: compact, rounded to centimetres, never smaller."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import shapely

from agv_app.geometry.area import XY, Area

__all__ = ["WIRE_MARGIN_M", "Coords", "coords_to_polygon", "polygon_to_coords"]

WIRE_MARGIN_M = 0.02
"""How far :func:`polygon_to_coords` grows a shape so that rounding never shrinks it."""

_MIN_HOLE_M2 = 0.01
"""Holes smaller than this (a 10 cm square) are filled on the wire: slivers that the
union of a projection's rectangles leaves at a sharp turn, which rounding to
centimetres would collapse into rings of one or two vertices. Filling a hole only
grows the area."""

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
        shell = _ring_flat(poly.exterior)
        if len(shell) < 6:  # too small to keep a shape at centimetres: its box, rounded out
            shell = _box_flat(poly.bounds)
        holes = [_ring_flat(r) for r in poly.interiors]
        out.append([shell, *(h for h in holes if len(h) >= 6 and _area(h) >= _MIN_HOLE_M2)])
    return out


def _box_flat(bounds: tuple[float, float, float, float]) -> list[float]:
    """The ring of the box ``bounds``, rounded outwards to centimetres."""
    x0, y0 = (math.floor(v * 100) / 100 for v in bounds[:2])
    x1, y1 = (math.ceil(v * 100) / 100 for v in bounds[2:])
    return [x0, y0, x1, y0, x1, y1, x0, y1]


def _area(flat: list[float]) -> float:
    """The area a flat ring encloses (shoelace)."""
    xs, ys = flat[0::2], flat[1::2]
    n = len(xs)
    return abs(sum(xs[k] * ys[(k + 1) % n] - xs[(k + 1) % n] * ys[k] for k in range(n))) / 2


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
