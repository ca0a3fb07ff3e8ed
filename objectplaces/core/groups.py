"""Group definitions: which nodes take part in a session.

A group definition is any callable ``(initiator_props, participant_props) -> bool``.
The declarative ones here are callables too, and say more about themselves: they
serialise to JSON (so the REST API and the dashboard can carry them) and they state a
*reach*, the largest distance from the initiator at which a candidate can still match.
The node engine uses the reach to ask its spatial index for candidates instead of
testing every node it knows, which is what makes a session among N nodes cost about
O(neighbours) per update rather than O(N).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeAlias

from mypy_extensions import mypyc_attr

from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.values import MAX_COORDINATE

__all__ = [
    "AllOf",
    "AnyOf",
    "CircleMeetsBox",
    "CirclesOverlap",
    "DefinitionLike",
    "GroupDefinition",
    "MaxOf",
    "Near",
    "PropertyEquals",
    "Reach",
    "Within",
    "checked_distance",
    "circle_meets_box",
    "circles_overlap",
    "describe",
    "distance",
    "near",
    "property_equals",
    "within",
]

Props: TypeAlias = Mapping[str, Any]
DefinitionLike: TypeAlias = Callable[[Props, Props], bool]
MaxOf: TypeAlias = Callable[[str], float]
"""Asks the index for the largest numeric value of a property over the known nodes."""


class Reach:
    """Candidates' ``position`` must lie within ``radius`` of ``centre``, or without one,
    of the initiator's ``position`` property."""

    __slots__ = ("centre", "position", "radius")

    def __init__(
        self, position: str, radius: float, centre: tuple[float, float] | None = None
    ) -> None:
        self.position = position
        self.radius = radius
        self.centre = centre

    def __repr__(self) -> str:
        return f"Reach({self.position!r}, {self.radius!r}, {self.centre!r})"


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


@mypyc_attr(allow_interpreted_subclasses=True)
class GroupDefinition(ABC):
    """A declarative, serialisable, spatially indexable group definition."""

    @abstractmethod
    def __call__(self, initiator: Props, participant: Props) -> bool:
        """True when ``participant`` belongs to the initiator's group."""

    @abstractmethod
    def to_json(self) -> dict[str, Any]:
        """A JSON-ready description that ``definition_from_json`` turns back into this."""

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        """The bound on candidates' distance, or None when any node may match."""
        return None

    def __and__(self, other: GroupDefinition) -> GroupDefinition:
        return AllOf(self, other)

    def __or__(self, other: GroupDefinition) -> GroupDefinition:
        return AnyOf(self, other)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, GroupDefinition) and self.to_json() == other.to_json()

    def __hash__(self) -> int:
        return hash(repr(self.to_json()))

    def __repr__(self) -> str:
        return f"definition_from_json({self.to_json()!r})"


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


class PropertyEquals(GroupDefinition):
    """Members: nodes whose property ``name`` equals ``value``."""

    def __init__(self, name: str, value: Any) -> None:
        self.name = name
        self.value = value

    def __call__(self, initiator: Props, participant: Props) -> bool:
        return self.name in participant and participant[self.name] == self.value

    def to_json(self) -> dict[str, Any]:
        return {"type": "property_equals", "name": self.name, "value": self.value}


class AllOf(GroupDefinition):
    """Members: nodes that satisfy every one of ``parts``."""

    def __init__(self, *parts: GroupDefinition) -> None:
        self.parts = parts

    def __call__(self, initiator: Props, participant: Props) -> bool:
        # A loop, not all() over a generator: half the cost, on every candidate tried.
        for part in self.parts:  # noqa: SIM110
            if not part(initiator, participant):
                return False
        return True

    def to_json(self) -> dict[str, Any]:
        return {"type": "and", "of": [part.to_json() for part in self.parts]}

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        # Any one bounded part bounds the conjunction; the tightest one is the best bound.
        reaches = [r for part in self.parts if (r := part.reach(initiator, max_of)) is not None]
        return min(reaches, key=lambda r: r.radius, default=None)


class AnyOf(GroupDefinition):
    """Members: nodes that satisfy at least one of ``parts``."""

    def __init__(self, *parts: GroupDefinition) -> None:
        self.parts = parts

    def __call__(self, initiator: Props, participant: Props) -> bool:
        return any(part(initiator, participant) for part in self.parts)

    def to_json(self) -> dict[str, Any]:
        return {"type": "or", "of": [part.to_json() for part in self.parts]}

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        # A disjunction is bounded only if every part is, around the same centre.
        reaches = [part.reach(initiator, max_of) for part in self.parts]
        if not reaches or any(r is None for r in reaches):
            return None
        bounded = [r for r in reaches if r is not None]
        if len({(r.position, r.centre) for r in bounded}) != 1:
            return None
        return max(bounded, key=lambda r: r.radius)


def describe(definition: DefinitionLike) -> Any:
    """A declarative definition's JSON form; any other callable's ``repr``."""
    return definition.to_json() if isinstance(definition, GroupDefinition) else repr(definition)


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


def property_equals(name: str, value: Any) -> PropertyEquals:
    """Nodes whose property ``name`` equals ``value``."""
    return PropertyEquals(name, value)
