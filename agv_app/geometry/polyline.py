"""Polylines: the path a vehicle drives, measured by arc length."""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Iterable
from dataclasses import dataclass

from agv_app.geometry.area import XY, Pose

__all__ = ["Polyline"]

_EPS = 1e-12


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
        """Position and heading at arc length ``s``: ``point_at`` and ``heading_at``
        with the piece found once (every AGV's pose is asked several times a step)."""
        coords = self.coords
        if len(coords) == 1:
            x, y = coords[0]
            return Pose(x, y, self.rest_heading_rad)
        s = self.clamp(s)
        i = self.piece_index(s)
        (x0, y0), (x1, y1) = coords[i], coords[i + 1]
        heading = math.atan2(y1 - y0, x1 - x0)
        s0, s1 = self.cumulative[i], self.cumulative[i + 1]
        t = (s - s0) / (s1 - s0)
        if t >= 1.0:
            return Pose(x1, y1, heading)
        return Pose(x0 + (x1 - x0) * t, y0 + (y1 - y0) * t, heading)

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
