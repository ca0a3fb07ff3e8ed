"""An area asked the same questions again and again, answered from memory.

A voter evaluates one request many times (at once, on every release of its own AGV,
and every recheck while it defers), against locks and a request that mostly stay the
same objects in its tuplespace, and from a requester that mostly stands where it
stood. :class:`Probe` keeps what those evaluations share: the request's vertices, its
reach from each position asked, and its overlap with each other area it met (areas
are immutable, so an answer about the same object stays true).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely

from agv_app.geometry.area import XY, Area, overlaps

__all__ = ["Probe"]

_MEMO_LIMIT = 64
"""Areas whose overlap a probe remembers; past that it starts over (a voter meets a
handful of locks in its session, so this bounds only a pathological one)."""


class Probe:
    """``area`` with its overlaps and its vertices remembered.

    Args:
        area: the area to probe with (never changed: areas are immutable).
    """

    __slots__ = ("_met", "_reach", "_vertices", "area")

    def __init__(self, area: Area) -> None:
        self.area = area
        self._vertices: Any = None
        self._reach: dict[XY, float] = {}  # position -> hull_length from there
        # id(other) -> (other, answer): the other is kept so that its id is not reused.
        self._met: dict[int, tuple[Area, bool]] = {}

    def overlaps(self, other: Area) -> bool:
        """``overlaps(self.area, other)`` with the default tolerance."""
        met = self._met.get(id(other))
        if met is not None and met[0] is other:
            return met[1]
        answer = overlaps(self.area, other)
        if len(self._met) >= _MEMO_LIMIT:
            self._met.clear()
        self._met[id(other)] = (other, answer)
        return answer

    def hull_length(self, position: XY) -> float:
        """``hull_length(position, [self.area])``: the distance to its furthest vertex."""
        reach = self._reach.get(position)
        if reach is None:
            reach = self._furthest(position)
            if len(self._reach) >= _MEMO_LIMIT:
                self._reach.clear()
            self._reach[position] = reach
        return reach

    def _furthest(self, position: XY) -> float:
        xy = self._vertices
        if xy is None:
            geom = self.area.geom
            xy = self._vertices = (
                np.empty((0, 2)) if geom.is_empty else shapely.get_coordinates([geom])
            )
        if len(xy) == 0:
            return 0.0
        d = np.hypot(xy[:, 0] - position[0], xy[:, 1] - position[1])
        return float(d.max())
