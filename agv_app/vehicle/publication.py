"""What an AGV publishes of itself: its circle (``position``, ``hull_length``) and status.

The hull length is the distance to the furthest point of its locked and requested
projections and claims, plus a small margin for rounding. The
:class:`~agv_app.vehicle.controller.AgvController` owns one :class:`Publication` and
publishes when a request reaches beyond the circle in force or the circle would be much
smaller; the middleware's beats and republications are the heartbeat.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

from agv_app.geometry import Area, hull_length

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = ["Circle", "Publication"]


class Circle(NamedTuple):
    """A circle the AGV published: centre, hull length, and when it went out."""

    x: float
    y: float
    radius: float
    since: float


class Publication:
    """The circle and status of one AGV (its controller's state, this job's logic).

    Args:
        agv: the controller whose AGV it publishes.
    """

    def __init__(self, agv: AgvController) -> None:
        self._agv = agv

    def areas(self) -> tuple[list[Area], Area | None]:
        """Locked projections and the requested one, from the tuplespace."""
        agv = self._agv
        book = agv.book
        request = book.request()
        return [e.area for e in book.locks()], None if request is None else request.area

    def current_hull_length(self) -> float:
        """Distance to the furthest point of locked and requested area, plus the margin.

        Claimed two-way segments count too (to their far end, plus half the hull's
        diagonal): whoever might drive them the other way is then in our group.
        """
        agv = self._agv
        pose = agv.vehicle.pose()
        return self.reach_from(pose.x, pose.y)

    def reach_from(self, x0: float, y0: float) -> float:
        """The hull length a circle centred at ``(x0, y0)`` needs, margin included."""
        agv = self._agv
        locks, request = self.areas()
        shapes = locks if request is None else [*locks, request]
        reach = hull_length((x0, y0), shapes)
        book = agv.book
        pending = book.request()
        claims = book.claims() | (frozenset() if pending is None else pending.claims)
        if claims:
            half = math.hypot(agv.spec.length_m, agv.spec.width_m) / 2
            for seg, _ in claims:
                for x, y in agv.layout.segment_coords(seg):
                    reach = max(reach, math.hypot(x - x0, y - y0) + half)
        return reach + agv.config.hull_margin_m

    def covered_since(self) -> float | None:
        """When the circle in force was published, if it covers the locks, the pending
        request and the claims; None if they reach beyond it (or none was published)."""
        agv = self._agv
        circle = agv._circle
        if circle is None or self.reach_from(circle.x, circle.y) > circle.radius:
            return None
        return circle.since

    def publish(self) -> None:
        """Publish position, hull length and status now."""
        agv = self._agv
        if agv.failed:
            return
        pose = agv.vehicle.pose()
        node = agv.node
        node.update_node_property("position", (pose.x, pose.y))
        # Rounded up to whole millimetres, so the wire's rounding never shrinks it.
        radius = math.ceil(self.current_hull_length() * 1000) / 1000
        node.update_node_property("hull_length", radius)
        agv._circle = Circle(pose.x, pose.y, radius, node.now())
        if node.properties.get("status") != agv.status:
            node.update_node_property("status", agv.status)
