"""Group definitions by distance: circles that overlap, a circle that meets a box,
nodes within a distance of the initiator or of a fixed point.

Each states its *reach* (``GroupDefinition.reach``), so the node resolves it through
its spatial index: a session costs about O(neighbours) per update, not O(view).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.groups import GroupDefinition, MaxOf, Props, Reach
from objectplaces.core.values import MAX_COORDINATE

__all__ = [
    "CircleMeetsBox",
    "CirclesOverlap",
    "Near",
    "Within",
    "checked_distance",
    "circle_meets_box",
    "circles_overlap",
    "distance",
    "near",
    "within",
]


def _point(props: Props, name: str) -> tuple[float, float] | None:
    value = props.get(name)
    if isinstance(value, tuple | list) and len(value) == 2:
        x, y = value
        if isinstance(x, int | float) and isinstance(y, int | float):
            return float(x), float(y)
    return None


def _radius(props: Props, name: str) -> float:
    """A node's radius property; 0 when it lacks one or it is not a number."""
    value = props.get(name, 0.0)
    return float(value) if isinstance(value, int | float) else 0.0


def distance(a: Props, b: Props, position: str = "position") -> float | None:
    """Euclidean distance between two nodes' positions, or None if either lacks one."""
    pa, pb = _point(a, position), _point(b, position)
    if pa is None or pb is None:
        return None
    return math.hypot(pa[0] - pb[0], pa[1] - pb[1])


class CirclesOverlap(GroupDefinition):
    """Members: nodes whose circle overlaps the initiator's, ``|p_i - p_j| <= r_i + r_j``.

    A node without a position never matches; a missing radius counts as 0.
    """

    def __init__(self, position: str = "position", radius: str = "hull_length") -> None:
        self.position = position
        self.radius = radius

    def __call__(self, initiator: Props, participant: Props) -> bool:
        a, b = _point(initiator, self.position), _point(participant, self.position)
        if a is None or b is None:
            return False
        reach = _radius(initiator, self.radius) + _radius(participant, self.radius)
        dx, dy = a[0] - b[0], a[1] - b[1]
        return dx * dx + dy * dy <= reach * reach

    def to_json(self) -> dict[str, Any]:
        return {"type": "circles_overlap", "position": self.position, "radius": self.radius}

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        return Reach(self.position, _radius(initiator, self.radius) + max_of(self.radius))


class CircleMeetsBox(GroupDefinition):
    """Members: nodes whose circle (centre ``position``, radius ``radius``) meets the
    axis-aligned box ``(x0, y0, x1, y1)``, whatever the initiator's properties.

    The box belongs to the definition, not to a node: one initiator's sessions may each
    name their own (e.g. around the area a session is about). A node without a position
    never matches; a missing radius counts as 0. The reach is taken around the
    initiator's ``position``, which an initiator without one lacks: then no node matches.
    """

    def __init__(
        self,
        box: Sequence[float],
        position: str = "position",
        radius: str = "hull_length",
    ) -> None:
        if (
            not isinstance(box, tuple | list)
            or len(box) != 4
            or not all(isinstance(v, int | float) and abs(v) <= MAX_COORDINATE for v in box)
            or box[0] > box[2]
            or box[1] > box[3]
        ):
            raise LocalProtocolError(
                f"circle_meets_box: box must be four numbers within +-{MAX_COORDINATE:g} "
                f"(positions' range), x0 <= x1 and y0 <= y1, as (x0, y0, x1, y1), got {box!r}"
            )
        x0, y0, x1, y1 = (float(v) for v in box)
        self.box = (x0, y0, x1, y1)
        self.position = position
        self.radius = radius

    def __call__(self, initiator: Props, participant: Props) -> bool:
        # ``_point`` and ``_radius`` written out, and ``max`` as comparisons: a request
        # group is tried on every node near its box when its session opens.
        value = participant.get(self.position)
        if not (isinstance(value, tuple | list) and len(value) == 2):
            return False
        px, py = value
        if not (isinstance(px, int | float) and isinstance(py, int | float)):
            return False
        px, py = float(px), float(py)
        r = participant.get(self.radius, 0.0)
        r = float(r) if isinstance(r, int | float) else 0.0
        x0, y0, x1, y1 = self.box
        # As max(x0 - px, 0, px - x1), a NaN included (it then matches nothing).
        dx = x0 - px if px < x0 else (px - x1 if px > x1 else (0.0 if px == px else px))
        dy = y0 - py if py < y0 else (py - y1 if py > y1 else (0.0 if py == py else py))
        return dx * dx + dy * dy <= r * r

    def to_json(self) -> dict[str, Any]:
        return {
            "type": "circle_meets_box",
            "box": list(self.box),
            "position": self.position,
            "radius": self.radius,
        }

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        # Every member's centre lies within the largest radius of the box, and the box
        # within its farthest corner of the initiator.
        own = _point(initiator, self.position)
        if own is None:
            return Reach(self.position, 0.0)
        x0, y0, x1, y1 = self.box
        corner = max(abs(own[0] - x0), abs(own[0] - x1)), max(abs(own[1] - y0), abs(own[1] - y1))
        return Reach(self.position, math.hypot(*corner) + max_of(self.radius))


def checked_distance(kind: str, distance: object) -> float:
    """``distance`` of a ``kind`` definition as a float, if it is a finite number >= 0.

    Raises:
        LocalProtocolError: it is not.
    """
    if not (isinstance(distance, int | float) and distance >= 0 and math.isfinite(distance)):
        raise LocalProtocolError(f"{kind}: distance must be a finite number >= 0, got {distance!r}")
    return float(distance)


class Within(GroupDefinition):
    """Members: nodes within ``distance`` of the initiator."""

    def __init__(self, distance: float, position: str = "position") -> None:
        self.distance = checked_distance("within", distance)
        self.position = position

    def __call__(self, initiator: Props, participant: Props) -> bool:
        d = distance(initiator, participant, self.position)
        return d is not None and d <= self.distance

    def to_json(self) -> dict[str, Any]:
        return {"type": "within", "distance": self.distance, "position": self.position}

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        return Reach(self.position, self.distance)


class Near(GroupDefinition):
    """Members: nodes within ``distance`` of the fixed ``point``, wherever the initiator
    is (one node may run sessions about several places: a transport base, its stations'
    auctions)."""

    def __init__(self, point: Sequence[float], distance: float, position: str = "position") -> None:
        if not (
            isinstance(point, tuple | list)
            and len(point) == 2
            and all(isinstance(v, int | float) and abs(v) <= MAX_COORDINATE for v in point)
        ):
            raise LocalProtocolError(
                f"near: point must be two numbers within +-{MAX_COORDINATE:g}, got {point!r}"
            )
        self.point = (float(point[0]), float(point[1]))
        self.distance = checked_distance("near", distance)
        self.position = position

    def __call__(self, initiator: Props, participant: Props) -> bool:
        other = _point(participant, self.position)
        return other is not None and math.dist(self.point, other) <= self.distance

    def to_json(self) -> dict[str, Any]:
        return {
            "type": "near",
            "point": list(self.point),
            "distance": self.distance,
            "position": self.position,
        }

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        return Reach(self.position, self.distance, self.point)


def circles_overlap(position: str = "position", radius: str = "hull_length") -> CirclesOverlap:
    """Nodes whose circles (centre ``position``, radius ``radius``) overlap the initiator's."""
    return CirclesOverlap(position, radius)


def circle_meets_box(
    box: tuple[float, float, float, float],
    position: str = "position",
    radius: str = "hull_length",
) -> CircleMeetsBox:
    """Nodes whose circles (centre ``position``, radius ``radius``) meet ``box``,
    ``(x0, y0, x1, y1)``."""
    return CircleMeetsBox(box, position, radius)


def within(distance: float, position: str = "position") -> Within:
    """Nodes within ``distance`` of the initiator's ``position``."""
    return Within(distance, position)


def near(point: tuple[float, float], distance: float, position: str = "position") -> Near:
    """Nodes whose ``position`` lies within ``distance`` of ``point``."""
    return Near(point, distance, position)
