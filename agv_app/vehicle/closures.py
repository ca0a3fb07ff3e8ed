"""How an AGV follows the closed parts of the floor (:mod:`agv_app.layout.blocked`).

The fleet gives every AGV component the open ways (``AgvController.ways``; None while
nothing is closed). The AGV routes over them alone, bids for no task whose pick or drop
station they cut off, and reacts to every change (:func:`ways_changed`):

* driving, with a closed path or point on the rest of its route: it ends the route at
  the route's last point before it (the first point it can still stop at; one driving
  on a closed path drives on to its end), and from there takes an open way on;
* standing on a closed point with nothing to do: it leaves by the shortest way out;
* waiting for a way (no open way led where it was going): it tries again.

Where no open way leads, it stands (:func:`wait_for_way`) and tries again at the next
change: reopened, it goes on. A vehicle that cannot stop before a closed path any more
(within its braking distance) drives on over it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from agv_app.tasks.auction import TaskSpec

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = ["serves", "wait_for_way", "ways_changed"]


def serves(agv: AgvController, task: TaskSpec) -> bool:
    """Whether an open way leads from the task's pick station to its drop station."""
    ways = agv.ways
    if ways is None:
        return True
    layout = agv.layout
    pick, drop = layout.station(task.pick).point, layout.station(task.drop).point
    return not math.isinf(ways.distance(pick, drop))


def wait_for_way(agv: AgvController, dest: str) -> bool:
    """No open way leads to ``dest``: stand and wait for one, or, standing on a closed
    point, leave by the shortest way out and wait there.

    Returns:
        Whether the AGV drives off (out of the closed area).
    """
    agv._dest = None
    agv._plan = None
    agv.blocked_to = dest
    ways = agv.ways
    if ways is None or not ways.is_closed(agv.point):
        return False
    way = ways.way_out(agv.point)
    if way is None:
        return False
    agv.blocked_to = None
    agv._resume = dest
    return agv.routing.route_to(way.end)


def ways_changed(agv: AgvController) -> None:
    """Something was closed or reopened: keep off what is closed, go on where a way
    opened (see the module docstring)."""
    if agv.failed:
        return
    target = agv.blocked_to
    if target is not None:
        agv.blocked_to = None
        agv.routing.route_to(target)
        agv.publish()
        return
    ways = agv.ways
    if ways is None:
        return
    if agv._dest is None:
        if agv.phase == "home" and ways.is_closed(agv.point):
            way = ways.way_out(agv.point)
            if way is not None:
                agv.phase = "to_home"
                agv.routing.route_to(way.end)
                agv.publish()
        return
    _stop_short(agv)


def _closed_ahead(agv: AgvController) -> int | None:
    """The index of the route's point the AGV stops at to keep off what is closed, or
    None when the rest of its route is open."""
    route, ways = agv._route, agv.ways
    if route is None or ways is None:
        return None
    reach = agv.vehicle.stopping_s() - agv._route_shift
    points, segments = ways.closed.points, ways.closed.segments
    first = next(
        (i for i, offset in enumerate(route.offsets) if offset >= reach - 1e-6),
        len(route.points) - 1,
    )
    for k in range(first, len(route.segments)):
        if route.segments[k] in segments or route.points[k + 1] in points:
            return k
    return None


def _stop_short(agv: AgvController) -> None:
    """End the route at its last point before what is closed; from there the AGV goes on
    to where it was going over open ways (or waits for one)."""
    if _closed_ahead(agv) is None:
        return
    requester = agv._requester
    if requester is not None and not requester.done:
        requester.withdraw()  # it asked for floor it will not drive
    k = _closed_ahead(agv)  # the withdrawal may have set the AGV on another way
    route, plan, dest = agv._route, agv._plan, agv._dest
    if k is None or route is None or plan is None or dest is None:
        return
    s = max(route.offsets[k] + agv._route_shift, agv.vehicle.s)
    agv.vehicle.shorten_route(s)
    agv._plan = plan.cut(s)
    agv._route = agv.layout.route_through(route.points[: k + 1])
    agv._dest = route.points[k]
    if agv._resume is None:
        agv._resume = dest
    agv.publish()
