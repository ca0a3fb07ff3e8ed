"""Where a fleet's AGVs rest: one home each, spread over the parking plan.

Both fleets park the same way: on the layout's parking spots, then its charging spots,
spread over the floor rather than packed into one corner, each vehicle facing along the
way into its spot. The simulated fleet may also rest AGVs on other points when a layout
(an openTCS demo) has too few spots, and hands out free rest points to an idle AGV that
stands in someone's way; the AGV processes of the mesh rest on their own home only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from agv_app.layout.graph import Layout
from agv_app.vehicle.kinematics import VehicleSpec

__all__ = ["ParkingPlan", "home_heading", "parking_capacity", "parking_spots"]


def parking_spots(layout: Layout) -> list[str]:
    """The distinct points of the usable parking, then charging, stations, in layout order."""
    usable = set(layout.usable_stations())
    points: list[str] = []
    for kind in ("parking", "charging"):
        for station in layout.stations_of_kind(kind):
            if station.id in usable and station.point not in points:
                points.append(station.point)
    return points


def parking_capacity(layout: Layout) -> int:
    """How many AGVs ``layout`` can hold: its distinct parking and charging points.

    An idle AGV rests on one of these, off the lanes. A fleet larger than this has to
    rest on lanes, and on a layout of one-way loops (openTCS Demo-01 has five parking
    spots) the resting AGVs block the loop until it gridlocks.
    """
    return len(parking_spots(layout))


def home_heading(layout: Layout, point: str) -> float:
    """The heading of a vehicle parked at ``point``: along the way into it (radians)."""
    p = layout.point(point)
    preds = [q for q in layout.neighbours(point) if point in layout.successors(q)]
    if not preds:
        return 0.0
    q = layout.point(preds[0])
    return math.atan2(p.y - q.y, p.x - q.x)


class ParkingPlan:
    """The homes of a fleet's AGVs and the rest points an idle one may move to.

    Args:
        layout: the floor plan.
        spec: the vehicles' size (rest points keep a hull diagonal apart).
        agvs: how many AGVs.
        homes: each AGV's home point (default: spread over the parking spots).
        rest_elsewhere: rest on other points (dead ends first, then lanes) when the
            layout has too few spots, and keep a few spare rest points to hand out.

    Raises:
        ValueError: the layout has room for fewer than ``agvs``.
    """

    def __init__(
        self,
        layout: Layout,
        spec: VehicleSpec,
        agvs: int,
        *,
        homes: Sequence[str] | None = None,
        rest_elsewhere: bool = True,
    ) -> None:
        self.layout = layout
        self.spec = spec
        if homes is not None:
            self.homes = list(homes)
            self._pool = list(self.homes)
        else:
            points = parking_spots(layout)
            if rest_elsewhere and len(points) < agvs:
                points += self._rest_points(points, agvs - len(points))
            if len(points) < agvs:
                raise ValueError(
                    f"layout {layout.name!r} has room to park {len(points)} AGVs, not {agvs}"
                )
            # Spread the fleet over the spots rather than packing one corner.
            self.homes = [points[(k * len(points)) // agvs] for k in range(agvs)]
            # The spots no AGV calls home come first, then a few points elsewhere.
            spare = [p for p in points if p not in self.homes]
            if rest_elsewhere:
                spare += self._rest_points(self.homes, max(4, agvs // 4))
            self._pool = self.homes + spare
        self._resting: dict[str, str] = {}
        """Rest point -> the AGV that owns it."""

    def claim(self, agv_id: str, point: str) -> None:
        """``agv_id`` owns rest point ``point`` (its home at the start)."""
        self._resting[point] = agv_id

    def relocate(
        self, agv_id: str, home: str, at: str, *, among: Sequence[str] | None = None
    ) -> str | None:
        """A free rest point for ``agv_id``, which owns ``home`` and stands at ``at``
        (``among``: one of these points instead, e.g. the chargers).

        The nearest free point by route wins (ties by point id); the AGV gives up its
        old point. None when no free point is reachable.
        """
        dist = self.layout.distances_from(at)
        pool = self._pool if among is None else among
        free = [p for p in pool if p not in self._resting and p in dist]
        if not free:
            return None
        best = min(free, key=lambda p: (dist[p], p))
        self._resting.pop(home, None)
        self._resting[best] = agv_id
        return best

    def set_aside(self, points: Sequence[str]) -> None:
        """Hand out none of ``points`` as a rest point (they stay homes if they are)."""
        keep = set(self.homes)
        self._pool = [p for p in self._pool if p in keep or p not in points]

    def owner(self, point: str) -> str | None:
        """The AGV that owns ``point`` (None: free)."""
        return self._resting.get(point)

    def _rest_points(self, taken: list[str], n: int) -> list[str]:
        """Up to ``n`` more points to rest on, a hull diagonal from each other, from
        stations and from junctions: dead ends first, then points on lanes.

        An AGV resting on a junction, or with its hull reaching into one, blocks every
        way through it; one that must leave across a way another AGV waits on locks
        with it.
        """
        layout = self.layout
        usable = {layout.station(s).point for s in layout.usable_stations()}
        reach = layout.distances_from(min(usable)) if usable else {}
        gap = math.hypot(self.spec.length_m, self.spec.width_m) + 0.5
        chosen: list[str] = []
        junctions = {p for p in layout.points if len(layout.neighbours(p)) > 2}
        occupied = [layout.point(p) for p in sorted({*taken, *usable, *junctions})]
        candidates = sorted(
            (
                p
                for p in layout.points
                if p in reach and p not in usable and p not in taken and _may_wait(layout, p)
            ),
            key=lambda p: (len(layout.neighbours(p)) > 1, p),
        )
        for pid in candidates:
            p = layout.point(pid)
            if all(math.hypot(p.x - q.x, p.y - q.y) >= gap for q in occupied):
                chosen.append(pid)
                occupied.append(p)
                if len(chosen) == n:
                    break
        return chosen


def _may_wait(layout: Layout, point: str) -> bool:
    """A vehicle may rest at ``point`` for long: a dead end, or off every two-way lane.

    One resting on a two-way run between junctions blocks it for everyone else, and one
    that must leave through it may meet one coming in (``traffic/deadlock.py``).
    """
    neighbours = layout.neighbours(point)
    return len(neighbours) <= 1 or not any(layout.is_bidirectional(point, q) for q in neighbours)
