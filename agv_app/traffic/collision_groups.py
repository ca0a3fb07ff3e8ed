"""The collision groups a request asks (:mod:`agv_app.traffic.collision`): the AGVs
whose circles meet the box around the requested area, every AGV in broadcast mode, and
the paper's circles-overlap group."""

from __future__ import annotations

from collections.abc import Iterable

from agv_app.geometry import Area
from agv_app.protocol import AGV_KIND
from agv_app.traffic.request_wire import WIRE_GROWTH_M
from objectplaces import groups
from objectplaces.groups import AllOf, CircleMeetsBox, GroupDefinition

__all__ = ["broadcast_group", "collision_group", "group_within", "request_group"]


def collision_group() -> GroupDefinition:
    """The collision-avoidance group: AGVs whose hull projection circles overlap.

    ``circles_overlap()`` restricted to AGVs, so stations (which have a position but
    no voter role) are not invited to decline every session.
    """
    return groups.circles_overlap() & groups.property_equals("kind", AGV_KIND)


def request_group(area: Area, claimed: Iterable[tuple[float, float]] = ()) -> GroupDefinition:
    """The collision group of one request: the AGVs whose circles meet the box around
    the requested area (grown as the wire grows it) and the claimed segments' vertices.

    Every AGV whose locked or requested areas, or claimed segments, the request may
    conflict with has them inside its circle, so its circle meets that box; an AGV
    whose circle only meets the requester's circle elsewhere (``collision_group``)
    cannot conflict with this request and need not vote (docs/traffic.md, "The
    collision group of a request").

    Args:
        area: the requested hull projection.
        claimed: the vertices of the segments the request claims a direction on.
    """
    extent = area.extent()
    if not extent:
        raise ValueError("a request's area is never empty")
    xs = [*extent[0::2], *(x for x, _ in claimed)]
    ys = [*extent[1::2], *(y for _, y in claimed)]
    grow = WIRE_GROWTH_M + 0.05
    box = (min(xs) - grow, min(ys) - grow, max(xs) + grow, max(ys) + grow)
    return groups.circle_meets_box(box) & groups.property_equals("kind", AGV_KIND)


def group_within(new: GroupDefinition, old: GroupDefinition) -> bool:
    """True if ``old`` takes every node ``new`` takes, whatever the view: they are
    equal, or both are request groups (``request_group``) and ``new``'s box lies in
    ``old``'s (a circle that meets the inner box meets the outer one).

    A request asked again whose group lies within the open session's may be asked on
    that session (:meth:`Requester.ask_again`): its members stay a superset of the new
    request's group for as long as the session runs.
    """
    if new == old:
        return True
    if not isinstance(new, AllOf) or not isinstance(old, AllOf):
        return False
    if len(new.parts) != len(old.parts):
        return False
    for inner, outer in zip(new.parts, old.parts, strict=True):
        if isinstance(inner, CircleMeetsBox) and isinstance(outer, CircleMeetsBox):
            (ix0, iy0, ix1, iy1), (ox0, oy0, ox1, oy1) = inner.box, outer.box
            if (inner.position, inner.radius) != (outer.position, outer.radius) or not (
                ox0 <= ix0 and oy0 <= iy0 and ix1 <= ox1 and iy1 <= oy1
            ):
                return False
        elif inner != outer:
            return False
    return True


def broadcast_group() -> GroupDefinition:
    """Every AGV, wherever it is: the comparison mode without groups."""
    return groups.property_equals("kind", AGV_KIND)
