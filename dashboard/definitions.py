"""Group definitions as the REST API accepts them: bounded, strict pydantic models.

A client's definition is validated here, once, before the middleware sees it: known
``type`` tags only, finite positive distances up to ``MAX_DISTANCE_M``, names that are
short non-empty strings, booleans never taken as numbers, at most
``MAX_DEFINITION_LEVELS`` levels of ``and``/``or`` and ``MAX_DEFINITION_PARTS`` parts in
all. ``build()`` then turns the model into the middleware's own declarative definition
(``objectplaces.groups``). The JSON form is the one ``GroupDefinition.to_json`` writes.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    StrictBool,
    StrictFloat,
    StrictInt,
    StrictStr,
    StringConstraints,
    TypeAdapter,
)
from pydantic_core import PydanticCustomError

from dashboard.limits import shown
from objectplaces import groups

__all__ = [
    "KINDS",
    "MAX_DEFINITION_LEVELS",
    "MAX_DEFINITION_PARTS",
    "MAX_DISTANCE_M",
    "MAX_NAME_LENGTH",
    "AllOfIn",
    "AnyOfIn",
    "CirclesOverlapIn",
    "DefinitionIn",
    "GroupDefinitionIn",
    "Name",
    "PropertyEqualsIn",
    "WithinIn",
    "definition_adapter",
]

MAX_DEFINITION_LEVELS = 32
"""Deepest nesting of ``and``/``or`` accepted (a single leaf is one level)."""

MAX_DEFINITION_PARTS = 256
"""Most definitions (leaves and combinations) one definition may hold in all."""

MAX_DISTANCE_M = 100_000.0
"""Largest ``within`` distance accepted, in metres: far beyond any floor plan, and far
from the range where grid arithmetic overflows."""

MAX_NAME_LENGTH = 128
"""Longest property, node or role name accepted."""

KINDS = ("circles_overlap", "within", "property_equals", "and", "or")
"""The ``type`` tags a definition may have."""

Name = Annotated[StrictStr, StringConstraints(min_length=1, max_length=MAX_NAME_LENGTH)]
"""A property, node or role name: a non-empty string of at most 128 characters."""

Scalar = (
    Annotated[StrictStr, StringConstraints(max_length=1024)]
    | Annotated[StrictInt, Field(ge=-(2**63), le=2**63 - 1)]
    | Annotated[StrictFloat, Field(allow_inf_nan=False)]
    | StrictBool
    | None
)


class _Definition(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)

    def build(self) -> groups.GroupDefinition:
        """The middleware's declarative definition this model describes."""
        raise NotImplementedError


class CirclesOverlapIn(_Definition):
    """Nodes whose circles overlap the initiator's: ``|p_i - p_j| <= r_i + r_j``."""

    type: Literal["circles_overlap"]
    position: Name = "position"
    radius: Name = "hull_length"

    def build(self) -> groups.GroupDefinition:
        """``groups.circles_overlap(position, radius)``."""
        return groups.circles_overlap(self.position, self.radius)


class WithinIn(_Definition):
    """Nodes within ``distance`` metres of the initiator."""

    type: Literal["within"]
    distance: float = Field(
        gt=0, le=MAX_DISTANCE_M, allow_inf_nan=False, description="metres, > 0 and <= 100000"
    )
    position: Name = "position"

    def build(self) -> groups.GroupDefinition:
        """``groups.within(distance, position)``."""
        return groups.within(self.distance, self.position)


class PropertyEqualsIn(_Definition):
    """Nodes whose property ``name`` equals ``value`` (a JSON scalar)."""

    type: Literal["property_equals"]
    name: Name
    value: Scalar

    def build(self) -> groups.GroupDefinition:
        """``groups.property_equals(name, value)``."""
        return groups.property_equals(self.name, self.value)


class AllOfIn(_Definition):
    """Nodes that satisfy every definition in ``of``."""

    type: Literal["and"]
    of: list[DefinitionIn] = Field(min_length=1, max_length=MAX_DEFINITION_PARTS)

    def build(self) -> groups.GroupDefinition:
        """``groups.AllOf(*of)``."""
        return groups.AllOf(*(part.build() for part in self.of))


class AnyOfIn(_Definition):
    """Nodes that satisfy at least one definition in ``of``."""

    type: Literal["or"]
    of: list[DefinitionIn] = Field(min_length=1, max_length=MAX_DEFINITION_PARTS)

    def build(self) -> groups.GroupDefinition:
        """``groups.AnyOf(*of)``."""
        return groups.AnyOf(*(part.build() for part in self.of))


def _check_shape(value: Any) -> Any:
    """Say plainly what is wrong with a definition before the union tries its members."""
    if not isinstance(value, dict):
        raise PydanticCustomError(
            "group_definition",
            "a group definition is a JSON object, got {value}",
            {"value": shown(value)},
        )
    kind = value.get("type")
    if kind not in KINDS:
        raise PydanticCustomError(
            "group_definition",
            "unknown group definition type {kind} (known: {known})",
            {"kind": shown(kind), "known": ", ".join(KINDS)},
        )
    if kind == "within" and "distance" not in value:
        raise PydanticCustomError(
            "group_definition", "group definition 'within' needs a 'distance'"
        )
    return value


def _check_size(value: Any) -> Any:
    """Refuse a definition nested deeper or holding more parts than allowed.

    Walks the raw JSON without recursion, before pydantic recurses into it.
    """
    parts = 0
    stack: list[tuple[Any, int]] = [(value, 1)]
    while stack:
        item, level = stack.pop()
        if not isinstance(item, dict):
            continue
        parts += 1
        if level > MAX_DEFINITION_LEVELS or parts > MAX_DEFINITION_PARTS:
            raise PydanticCustomError(
                "group_definition_size",
                "a group definition may nest at most {levels} levels and hold at most "
                "{parts} parts",
                {"levels": MAX_DEFINITION_LEVELS, "parts": MAX_DEFINITION_PARTS},
            )
        of = item.get("of")
        if item.get("type") in ("and", "or") and isinstance(of, list):
            stack.extend((part, level + 1) for part in of)
    return value


DefinitionIn = Annotated[
    CirclesOverlapIn | WithinIn | PropertyEqualsIn | AllOfIn | AnyOfIn,
    Field(discriminator="type"),
    BeforeValidator(_check_shape),
]
"""One declarative group definition (any level of a nested one)."""

AllOfIn.model_rebuild()
AnyOfIn.model_rebuild()

GroupDefinitionIn = Annotated[DefinitionIn, BeforeValidator(_check_size)]
"""A whole group definition from a client, size limits included."""

definition_adapter: TypeAdapter[
    CirclesOverlapIn | WithinIn | PropertyEqualsIn | AllOfIn | AnyOfIn
] = TypeAdapter(GroupDefinitionIn)
"""Validates a whole definition (size limits included) from parsed JSON."""
