"""Areas on the floor: poses, the immutable :class:`Area`, overlap and reach.

shapely has no type stubs, so shapely objects travel inside :class:`Area`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

__all__ = [
    "DEFAULT_OVERLAP_TOLERANCE_M2",
    "XY",
    "Area",
    "Pose",
    "Spine",
    "boxes_apart",
    "hull_length",
    "overlaps",
]

XY = tuple[float, float]
"""A point on the floor, ``(x, y)`` in metres."""

DEFAULT_OVERLAP_TOLERANCE_M2 = 1e-6
"""Intersections smaller than this (1 mm²) do not count as an overlap."""


@dataclass(frozen=True, slots=True)
class Pose:
    """Where a vehicle stands: position in metres and heading in radians (0 = +x)."""

    x: float
    y: float
    heading_rad: float


@dataclass(frozen=True, slots=True)
class Spine:
    """Points known to lie deep inside an area: every point of ``geom`` (a shapely
    point or line) is at least ``clearance`` metres from the area's edge.

    An overlap test may take a point of the spine that lies deep inside the other
    area as proof of an overlap, without working out the intersection
    (:class:`agv_app.geometry.probe.Probe`).
    """

    geom: Any
    clearance: float


class Area:
    """An immutable area on the floor (a shapely polygon or multipolygon, maybe empty).

    The raw shapely object is available as :attr:`geom` for callers that need
    more than the methods here; do not mutate it. :attr:`spine`, when known (hull
    projections), names points deep inside it.
    """

    __slots__ = ("_extent", "geom", "spine")

    geom: Any
    spine: Spine | None
    _extent: tuple[float, float, float, float] | tuple[()] | None

    def __init__(self, geom: Any, spine: Spine | None = None) -> None:
        """Wrap a shapely geometry (use :meth:`empty` for nothing)."""
        object.__setattr__(self, "geom", geom)
        object.__setattr__(self, "spine", spine)
        # The bounding box, worked out on the first overlap test (see ``extent``).
        object.__setattr__(self, "_extent", None)

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

    def extent(self) -> tuple[float, float, float, float] | tuple[()]:
        """``bounds``, remembered (an area is tested for overlap again and again);
        ``()`` when the area is empty."""
        extent = self._extent
        if extent is None:
            extent = () if self.geom.is_empty else tuple(self.geom.bounds)
            object.__setattr__(self, "_extent", extent)
        return extent

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


def boxes_apart(a: Area, b: Area) -> bool:
    """True if ``a`` or ``b`` is empty or their bounding boxes do not meet: then the
    areas share no point (the cheap test before any exact one)."""
    box_a, box_b = a.extent(), b.extent()
    if not box_a or not box_b:
        return True
    ax0, ay0, ax1, ay1 = box_a
    bx0, by0, bx1, by1 = box_b
    return ax1 < bx0 or bx1 < ax0 or ay1 < by0 or by1 < ay0


def overlaps(a: Area, b: Area, *, tolerance_m2: float = DEFAULT_OVERLAP_TOLERANCE_M2) -> bool:
    """True if the interiors of ``a`` and ``b`` share more than ``tolerance_m2`` square metres.

    Touching edges or corners is not an overlap: two hulls parked bumper to bumper
    are safe, and the tolerance keeps floating-point slivers from raising false
    alarms. Any real encroachment (1 mm x 1 m is already 10x the default) counts.
    """
    if boxes_apart(a, b):
        return False
    ga, gb = a.geom, b.geom
    if not shapely.intersects(ga, gb):
        return False
    return float(shapely.intersection(ga, gb).area) > tolerance_m2
