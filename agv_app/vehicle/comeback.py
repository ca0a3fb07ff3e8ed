"""Coming back where the vehicle stands: an AGV whose process restarted (a crash, a
power cycle) takes up its vehicle where the driver says it is, not at its home.

:func:`come_back` runs when a controller is built with a driver. It finds where the
vehicle stands on the layout (:func:`locate`): on a point, the AGV rests there; on a
segment, it drives on to the segment's next point first (on a two-way segment the one
it faces), then as any AGV does. Its first lock is the hull it stands in, as always;
before it asks for any floor it publishes its circle there and waits the safe time
(:func:`announce`), so every AGV that could meet it hears of it before it moves.

The task it held goes back to the transport base (:class:`HandBack`): the AGV publishes
``task`` None and ``returned`` with the task's id, and, if the load is on board (it had
left the pick station), ``reached_pick`` with the id too. It is free then. The base
decides: it awards the task to this AGV again, which resumes it (to the drop station
straight away when loaded), or it puts the task back in its queue (docs/drivers.md,
"Coming back").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from agv_app.geometry import Polyline, Pose
from agv_app.layout.graph import Layout
from agv_app.tasks.auction import TaskSpec
from agv_app.vehicle.state_file import StateFileError
from objectplaces import RoleActivator

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = [
    "HandBack",
    "LocationError",
    "Placement",
    "announce",
    "come_back",
    "hand_back",
    "held_from_json",
    "held_to_json",
    "locate",
]

ON_POINT_M = 0.01
"""A vehicle this close to a point (plus its localization error) stands on it."""
ON_SEGMENT_M = 0.1
"""A vehicle this close to a segment (plus its localization error) stands on it."""


class LocationError(ValueError):
    """The vehicle stands on no point and no segment of the layout."""


@dataclass(frozen=True, slots=True)
class Placement:
    """Where a vehicle stands on a layout.

    Attributes:
        point: the point it stands on, or the one it drives to first.
        back: on a segment, the point behind it (None: it stands on ``point``).
        s: on a segment, how far from ``back`` it stands, along the segment.
    """

    point: str
    back: str | None = None
    s: float = 0.0


def locate(layout: Layout, pose: Pose, *, tolerance_m: float = 0.0) -> Placement:
    """Where ``pose`` lies on ``layout``: the nearest point within ``ON_POINT_M``, else
    the nearest segment within ``ON_SEGMENT_M`` (both grown by ``tolerance_m``), driven
    in its direction (a two-way one in the direction ``pose`` faces, or the other: the
    hull is the same both ways).

    Raises:
        LocationError: nothing of the layout lies that close.
    """
    near = min(
        ((math.hypot(p.x - pose.x, p.y - pose.y), pid) for pid, p in layout.points.items()),
        default=None,
    )
    if near is not None and near[0] <= ON_POINT_M + tolerance_m:
        return Placement(near[1])
    best: tuple[float, str, Placement] | None = None
    for seg_id, segment in sorted(layout.segments.items()):
        line = Polyline(layout.segment_coords(seg_id))
        distance, s = _nearest(line, pose.x, pose.y)
        if distance > ON_SEGMENT_M + tolerance_m or (best is not None and distance >= best[0]):
            continue
        facing = math.cos(pose.heading_rad - line.heading_at(s)) >= 0.0
        if segment.bidirectional and not facing:
            placement = Placement(segment.start, segment.end, line.length - s)
        else:
            placement = Placement(segment.end, segment.start, s)
        best = (distance, seg_id, placement)
    if best is None:
        raise LocationError(f"({pose.x:.3f}, {pose.y:.3f}) lies on no point or segment")
    return best[2]


def _nearest(line: Polyline, x: float, y: float) -> tuple[float, float]:
    """Distance from ``(x, y)`` to ``line`` and the arc length of its nearest point."""
    best = (math.inf, 0.0)
    for i in range(len(line.coords) - 1):
        (x0, y0), (x1, y1) = line.coords[i], line.coords[i + 1]
        dx, dy = x1 - x0, y1 - y0
        t = min(1.0, max(0.0, ((x - x0) * dx + (y - y0) * dy) / (dx * dx + dy * dy)))
        d = math.hypot(x0 + t * dx - x, y0 + t * dy - y)
        if d < best[0]:
            best = (d, line.cumulative[i] + t * (line.cumulative[i + 1] - line.cumulative[i]))
    return best


def come_back(agv: AgvController) -> None:
    """Take up the vehicle where its driver says it stands (the module docstring).

    Raises:
        LocationError: it stands off the layout (move it onto a path by hand).
    """
    vehicle = agv.vehicle
    place = locate(agv.layout, vehicle.pose(), tolerance_m=2 * vehicle.limits.localization_error_m)
    if place.back is None:
        agv.point = place.point
        agv.phase = "home" if place.point == agv.home else "lost"
    else:
        # Drive on to the segment's end along its route: the plan knows the segment.
        route = agv.layout.route_through([place.back, place.point])
        agv.point = place.back
        agv.routing.route_to(None)  # a fresh start: no plan, no first try
        agv.routing.follow(route, route.polyline, shift=0.0, start_s=min(place.s, route.length))
        agv._dest = place.point
        agv.phase = "lost"
    announce(agv)


def announce(agv: AgvController) -> None:
    """Publish the AGV's circle now and ask for no floor for the safe time (twice the
    property interval): everyone that could meet it hears of it before it moves."""
    agv.publish()
    agv._retry_at = agv.node.now() + 2 * agv.config.t_update


@dataclass(slots=True)
class HandBack:
    """A task the AGV held before its process restarted, now handed back.

    Attributes:
        task: the task.
        loaded: the load is on board (the AGV had left the pick station).
    """

    task: TaskSpec
    loaded: bool

    def publish(self, node: RoleActivator) -> None:
        """Tell the transport base: ``returned``, and ``reached_pick`` when loaded."""
        node.update_node_property("returned", self.task.id)
        if self.loaded:
            node.update_node_property("reached_pick", self.task.id)

    def resumed(self, node: RoleActivator, task: TaskSpec) -> bool:
        """The AGV sets off with ``task``: the base has decided. True if it is this
        task with the load on board (it goes to the drop station)."""
        node.update_node_property("returned", None)
        return self.loaded and task.id == self.task.id


def hand_back(agv: AgvController, task: TaskSpec, *, loaded: bool) -> None:
    """Hand ``task``, which the AGV held before it came back, to the transport base."""
    agv.handed_back = back = HandBack(task, loaded)
    back.publish(agv.node)


def held_to_json(agv: AgvController) -> dict[str, Any] | None:
    """The task the AGV holds, for its process's state file (None: none)."""
    if agv.task is not None:
        return {"task": agv.task.to_message(), "loaded": agv.phase in ("to_drop", "at_drop")}
    if agv.pending_task is not None:
        return {"task": agv.pending_task.to_message(), "loaded": False}
    back = agv.handed_back
    if back is not None:
        return {"task": back.task.to_message(), "loaded": back.loaded}
    return None


def held_from_json(document: Any) -> tuple[TaskSpec, bool] | None:
    """The task and whether it was loaded, from :func:`held_to_json`'s form.

    Raises:
        StateFileError: not that form.
    """
    if document is None:
        return None
    task = TaskSpec.from_message(document.get("task")) if isinstance(document, dict) else None
    loaded = document.get("loaded") if isinstance(document, dict) else None
    if task is None or not isinstance(loaded, bool):
        raise StateFileError(f"expected a held task, got {document!r}")
    return task, loaded
