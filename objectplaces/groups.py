"""Group definitions: any callable ``(initiator_props, participant_props) -> bool``, or
the declarative ones here, which serialise to JSON and resolve through a spatial index.

Combine them with ``&`` (both) and ``|`` (either), a plain callable included:
``within(40) & (lambda i, p: p.get("status") == "idle")`` keeps the spatial index of
``within`` (the callable is tried only on nodes within 40 m) but has no JSON form.
"""

from __future__ import annotations

from objectplaces.core.comparisons import (
    PropertyAbove,
    PropertyBelow,
    PropertyEquals,
    PropertyIn,
    property_above,
    property_below,
    property_equals,
    property_in,
)
from objectplaces.core.group_json import definition_from_json
from objectplaces.core.groups import (
    AllOf,
    AnyOf,
    DefinitionLike,
    GroupDefinition,
    Predicate,
    Reach,
)
from objectplaces.core.proximity import (
    CircleMeetsBox,
    CirclesOverlap,
    Near,
    Within,
    circle_meets_box,
    circles_overlap,
    distance,
    near,
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
    "Predicate",
    "PropertyAbove",
    "PropertyBelow",
    "PropertyEquals",
    "PropertyIn",
    "Reach",
    "Within",
    "circle_meets_box",
    "circles_overlap",
    "definition_from_json",
    "distance",
    "near",
    "property_above",
    "property_below",
    "property_equals",
    "property_in",
    "within",
]
