"""Group definitions: any callable ``(initiator_props, participant_props) -> bool``, or
the declarative ones here, which serialise to JSON and resolve through a spatial index."""

from __future__ import annotations

from objectplaces.core.group_json import definition_from_json
from objectplaces.core.groups import (
    AllOf,
    AnyOf,
    CircleMeetsBox,
    CirclesOverlap,
    DefinitionLike,
    GroupDefinition,
    Near,
    PropertyEquals,
    Within,
    circle_meets_box,
    circles_overlap,
    distance,
    near,
    property_equals,
    within,
)

__all__ = [
    "AllOf",
    "AnyOf",
    "CircleMeetsBox",
    "CirclesOverlap",
    "DefinitionLike",
    "GroupDefinition",
    "Near",
    "PropertyEquals",
    "Within",
    "circle_meets_box",
    "circles_overlap",
    "definition_from_json",
    "distance",
    "near",
    "property_equals",
    "within",
]
