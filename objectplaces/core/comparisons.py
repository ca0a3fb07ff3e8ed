"""Group definitions over one property of the candidate: equal to a value, above or
below a number, one of a set of values.

They have no reach (any node may match), so on their own they test every node in the
view; combined with a spatial definition (``within(40) & property_above("battery",
50)``) they are tried only on the nodes the spatial part's reach leaves. Each has a
JSON form (``definition_from_json`` reads it back), like every declarative definition.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.groups import GroupDefinition, Props

__all__ = [
    "PropertyAbove",
    "PropertyBelow",
    "PropertyEquals",
    "PropertyIn",
    "property_above",
    "property_below",
    "property_equals",
    "property_in",
]


def _name(kind: str, name: object) -> str:
    if not isinstance(name, str) or not name:
        raise LocalProtocolError(f"{kind}: name must be a non-empty string, got {name!r}")
    return name


def _number(kind: str, value: object) -> float:
    # A bool is an int to Python, but "battery > True" is a mistake, not a threshold.
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise LocalProtocolError(f"{kind}: value must be a finite number, got {value!r}")
    return float(value)


def _numeric(props: Props, name: str) -> float | None:
    """The candidate's property ``name`` as a number; None when it lacks one (a bool
    is no number here either)."""
    value = props.get(name)
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value)


class PropertyEquals(GroupDefinition):
    """Members: nodes whose property ``name`` equals ``value``."""

    def __init__(self, name: str, value: Any) -> None:
        self.name = _name("property_equals", name)
        self.value = value

    def __call__(self, initiator: Props, participant: Props) -> bool:
        return self.name in participant and participant[self.name] == self.value

    def to_json(self) -> dict[str, Any]:
        return {"type": "property_equals", "name": self.name, "value": self.value}


class PropertyAbove(GroupDefinition):
    """Members: nodes whose property ``name`` is a number greater than ``value``. A node
    without it, or with a value that is no number, never matches."""

    def __init__(self, name: str, value: float) -> None:
        self.name = _name("property_above", name)
        self.value = _number("property_above", value)

    def __call__(self, initiator: Props, participant: Props) -> bool:
        value = _numeric(participant, self.name)
        return value is not None and value > self.value

    def to_json(self) -> dict[str, Any]:
        return {"type": "property_above", "name": self.name, "value": self.value}


class PropertyBelow(GroupDefinition):
    """Members: nodes whose property ``name`` is a number less than ``value``. A node
    without it, or with a value that is no number, never matches."""

    def __init__(self, name: str, value: float) -> None:
        self.name = _name("property_below", name)
        self.value = _number("property_below", value)

    def __call__(self, initiator: Props, participant: Props) -> bool:
        value = _numeric(participant, self.name)
        return value is not None and value < self.value

    def to_json(self) -> dict[str, Any]:
        return {"type": "property_below", "name": self.name, "value": self.value}


class PropertyIn(GroupDefinition):
    """Members: nodes whose property ``name`` equals one of ``values``."""

    def __init__(self, name: str, values: Iterable[Any]) -> None:
        self.name = _name("property_in", name)
        if isinstance(values, str | bytes) or not isinstance(values, Iterable):
            raise LocalProtocolError(
                f"property_in: values must be a list of values, got {values!r}"
            )
        self.values = tuple(values)

    def __call__(self, initiator: Props, participant: Props) -> bool:
        return self.name in participant and participant[self.name] in self.values

    def to_json(self) -> dict[str, Any]:
        return {"type": "property_in", "name": self.name, "values": list(self.values)}


def property_equals(name: str, value: Any) -> PropertyEquals:
    """Nodes whose property ``name`` equals ``value``."""
    return PropertyEquals(name, value)


def property_above(name: str, value: float) -> PropertyAbove:
    """Nodes whose property ``name`` is a number greater than ``value``.

    Raises:
        LocalProtocolError: ``name`` is not a non-empty string or ``value`` not a finite
            number.
    """
    return PropertyAbove(name, value)


def property_below(name: str, value: float) -> PropertyBelow:
    """Nodes whose property ``name`` is a number less than ``value``.

    Raises:
        LocalProtocolError: ``name`` is not a non-empty string or ``value`` not a finite
            number.
    """
    return PropertyBelow(name, value)


def property_in(name: str, values: Iterable[Any]) -> PropertyIn:
    """Nodes whose property ``name`` equals one of ``values`` (a list, not a string).

    Raises:
        LocalProtocolError: ``name`` is not a non-empty string or ``values`` not a list.
    """
    return PropertyIn(name, values)
