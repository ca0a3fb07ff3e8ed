"""The wire form of an area: compact, rounded to centimetres, never smaller."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import shapely

from agv_app.geometry.area import XY, Area

__all__ = ["WIRE_MARGIN_M", "Coords", "coords_to_polygon", "polygon_to_coords"]

WIRE_MARGIN_M = 0.02
"""How far :func:`polygon_to_coords` grows a shape so that rounding never shrinks it."""

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
