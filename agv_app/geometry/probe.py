"""An area asked the same questions again and again, answered from memory.

A voter evaluates one request many times (at once, on every release of its own AGV,
and every recheck while it defers), against locks and a request that mostly stay the
same objects in its tuplespace, and from a requester that mostly stands where it
stood. :class:`Probe` keeps what those evaluations share: the request's vertices, its
reach from each position asked, and its overlap with each other area it met (areas
are immutable, so an answer about the same object stays true).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely

from agv_app.geometry.area import DEFAULT_OVERLAP_TOLERANCE_M2, XY, Area, boxes_apart, overlaps

__all__ = ["Probe"]

_MEMO_LIMIT = 64
"""Areas whose overlap a probe remembers; past that it starts over (a voter meets a
handful of locks in its session, so this bounds only a pathological one)."""

_INSET_M = 0.01
"""How far inside its edge a point of the probed area must lie to prove an overlap."""

_PROOF_M = 0.5 * _INSET_M
"""The radius of the disc such a point is taken to prove: the inset's arcs are drawn
as chords, a fraction of a per cent inside the true ones, and half leaves room."""

assert math.pi * _PROOF_M**2 > DEFAULT_OVERLAP_TOLERANCE_M2  # the disc is an overlap


class Probe:
    """``area`` with its overlaps and its vertices remembered.

    Args:
        area: the area to probe with (never changed: areas are immutable).
    """

    __slots__ = ("_inset", "_met", "_reach", "_vertices", "area")

    def __init__(self, area: Area) -> None:
        self.area = area
        self._vertices: Any = None
        self._inset: Any = None  # the area shrunk by _INSET_M, prepared; False: empty
        self._reach: dict[XY, float] = {}  # position -> hull_length from there
        # id(other) -> (other, answer): the other is kept so that its id is not reused.
        self._met: dict[int, tuple[Area, bool]] = {}

    def overlaps(self, other: Area) -> bool:
        """``overlaps(self.area, other)`` with the default tolerance."""
        met = self._met.get(id(other))
        if met is not None and met[0] is other:
            return met[1]
        answer = self._surely_overlaps(other) or overlaps(self.area, other)
        if len(self._met) >= _MEMO_LIMIT:
            self._met.clear()
        self._met[id(other)] = (other, answer)
        return answer

    def _surely_overlaps(self, other: Area) -> bool:
        """True if a point of ``other``'s spine lies ``_INSET_M`` inside this area: a
        disc around it lies in both, larger than the tolerance, so ``overlaps`` would
        say True. False says nothing (``overlaps`` decides then)."""
        spine = other.spine
        if spine is None or spine.clearance < _PROOF_M:
            return False
        if boxes_apart(self.area, other):
            return False
        inset = self._inset
        if inset is None:
            inset = self.area.geom.buffer(-_INSET_M)
            if inset.is_empty:
                inset = False
            else:
                shapely.prepare(inset)
            self._inset = inset
        return inset is not False and bool(shapely.intersects(inset, spine.geom))

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
