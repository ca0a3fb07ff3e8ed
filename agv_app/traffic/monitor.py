"""The safety monitor: no two locked projections overlap, no two hulls intersect.

Checked at every simulation step over every AGV, failed ones included (their hull
stays on the floor). A packed R-tree of the bounding boxes (shapely's ``STRtree``)
finds the pairs whose boxes may meet in about O(n log n), where comparing every box
with every other grows with n squared (a million pairs per step at 1,000 AGVs); the
strict box test then keeps exactly the pairs the all-pairs comparison keeps, and only
those are intersected exactly. Overlaps below a tiny area tolerance are floating-point
slivers, not violations (see ``geometry.overlaps``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from agv_app.geometry import DEFAULT_OVERLAP_TOLERANCE_M2, Area

__all__ = ["SafetyMonitor", "SafetyViolation"]


@dataclass(frozen=True, slots=True)
class SafetyViolation:
    """One violation: what overlapped, between which AGVs, where and when.

    Attributes:
        step: simulation step number.
        time: simulated seconds.
        kind: ``"collision"`` (hulls) or ``"lock_overlap"`` (locked projections).
        agvs: the two AGV ids, sorted.
        shapes: the two shapes as WKT, in the order of ``agvs``.
        area_m2: size of the overlap.
    """

    step: int
    time: float
    kind: str
    agvs: tuple[str, str]
    shapes: tuple[str, str]
    area_m2: float

    def __str__(self) -> str:
        return (
            f"step {self.step} (t={self.time:.1f} s): {self.kind} between {self.agvs[0]} and "
            f"{self.agvs[1]} ({self.area_m2:.4f} m2): {self.shapes[0]} / {self.shapes[1]}"
        )


def _pairs(items: Sequence[tuple[str, Area]]) -> list[tuple[int, int]]:
    """Index pairs ``i < j`` of items of different owners whose bounding boxes overlap
    (touching is not overlapping), sorted."""
    n = len(items)
    if n < 2:
        return []
    geoms = np.empty(n, dtype=object)
    geoms[:] = [a.geom for _, a in items]
    boxes = shapely.bounds(geoms)
    # The tree's query counts touching boxes and empty ones never: the strict test
    # below decides, as the all-pairs comparison did.
    i, j = shapely.STRtree(geoms).query(geoms)
    keep = i < j
    i, j = i[keep], j[keep]
    x0, y0, x1, y1 = boxes[:, 0], boxes[:, 1], boxes[:, 2], boxes[:, 3]
    owners = np.array([hash(o) for o, _ in items])
    meet = (
        (x0[i] < x1[j])
        & (x0[j] < x1[i])
        & (y0[i] < y1[j])
        & (y0[j] < y1[i])
        & (owners[i] != owners[j])
    )
    i, j = i[meet], j[meet]
    order = np.lexsort((j, i))
    return [(int(a), int(b)) for a, b in zip(i[order], j[order], strict=True)]


class SafetyMonitor:
    """Counts collisions and lock overlaps; keeps the first violations for the report.

    Args:
        tolerance_m2: overlaps up to this area are ignored.
        keep: how many violations to keep in full.
    """

    def __init__(
        self, *, tolerance_m2: float = DEFAULT_OVERLAP_TOLERANCE_M2, keep: int = 20
    ) -> None:
        self.tolerance_m2 = tolerance_m2
        self.keep = keep
        self.collisions = 0
        self.lock_overlaps = 0
        self.violations: list[SafetyViolation] = []
        self._ongoing: set[tuple[str, str, str]] = set()

    def check(
        self,
        step: int,
        time: float,
        hulls: Sequence[tuple[str, Area]],
        locks: Sequence[tuple[str, Area]],
    ) -> list[SafetyViolation]:
        """Check one step; return its new violations (a lasting overlap counts once).

        Args:
            step: the step number.
            time: simulated seconds.
            hulls: ``(agv id, hull)`` of every AGV.
            locks: ``(agv id, locked projection)``, any number per AGV.
        """
        found: list[SafetyViolation] = []
        now: set[tuple[str, str, str]] = set()
        for kind, items in (("collision", hulls), ("lock_overlap", locks)):
            for i, j in _pairs(items):
                (a, ga), (b, gb) = items[i], items[j]
                if ga.is_empty or gb.is_empty:
                    continue
                inter = ga.intersection(gb).area_m2
                if inter <= self.tolerance_m2:
                    continue
                if a > b:
                    (a, ga), (b, gb) = (b, gb), (a, ga)
                key = (kind, a, b)
                now.add(key)
                if key in self._ongoing:
                    continue
                v = SafetyViolation(step, time, kind, (a, b), (ga.geom.wkt, gb.geom.wkt), inter)
                found.append(v)
        self._ongoing = now
        for v in found:
            if v.kind == "collision":
                self.collisions += 1
            else:
                self.lock_overlaps += 1
            if len(self.violations) < self.keep:
                self.violations.append(v)
        return found
