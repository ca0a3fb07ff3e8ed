"""Group definitions from their JSON form: what the REST API, the dashboard and the
command line carry (each declarative definition's ``to_json`` is the other way)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from objectplaces.core.comparisons import PropertyAbove, PropertyBelow, PropertyEquals, PropertyIn
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.groups import AllOf, AnyOf, GroupDefinition
from objectplaces.core.proximity import (
    CircleMeetsBox,
    CirclesOverlap,
    Near,
    Within,
    checked_distance,
)

__all__ = ["definition_from_json"]


def _string(obj: Mapping[str, Any], key: str, default: str) -> str:
    value = obj.get(key, default)
    if not isinstance(value, str) or not value:
        raise LocalProtocolError(
            f"group definition field {key!r} must be a non-empty string, got {value!r}"
        )
    return value


def definition_from_json(obj: Any) -> GroupDefinition:
    """Build a declarative definition from its JSON form (see each class's ``to_json``).

    Raises:
        LocalProtocolError: the object is not a valid definition; the message says why.
    """
    if not isinstance(obj, Mapping):
        raise LocalProtocolError(f"a group definition is a JSON object, got {obj!r}")
    kind = obj.get("type")
    match kind:
        case "circles_overlap":
            return CirclesOverlap(
                _string(obj, "position", "position"), _string(obj, "radius", "hull_length")
            )
        case "circle_meets_box":
            return CircleMeetsBox(
                obj.get("box"),  # type: ignore[arg-type]  # checked there
                _string(obj, "position", "position"),
                _string(obj, "radius", "hull_length"),
            )
        case "within":
            if "distance" not in obj:
                raise LocalProtocolError("group definition 'within' needs a 'distance'")
            # Checked before the call: a compiled build refuses a wrong type first.
            distance = checked_distance("within", obj["distance"])
            return Within(distance, _string(obj, "position", "position"))
        case "near":
            if "distance" not in obj or "point" not in obj:
                raise LocalProtocolError("group definition 'near' needs a 'point' and a 'distance'")
            distance = checked_distance("near", obj["distance"])
            return Near(obj["point"], distance, _string(obj, "position", "position"))
        case "property_equals":
            if "value" not in obj:
                raise LocalProtocolError("group definition 'property_equals' needs a 'value'")
            return PropertyEquals(_string(obj, "name", ""), obj["value"])
        case "property_above" | "property_below":
            if "value" not in obj:
                raise LocalProtocolError(f"group definition {kind!r} needs a 'value'")
            cls = PropertyAbove if kind == "property_above" else PropertyBelow
            return cls(_string(obj, "name", ""), obj["value"])
        case "property_in":
            values = obj.get("values")
            if not isinstance(values, list):
                raise LocalProtocolError("group definition 'property_in' needs a list 'values'")
            return PropertyIn(_string(obj, "name", ""), values)
        case "and" | "or":
            parts = obj.get("of")
            if not isinstance(parts, list) or not parts:
                raise LocalProtocolError(f"group definition {kind!r} needs a non-empty list 'of'")
            built = [definition_from_json(part) for part in parts]
            return AllOf(*built) if kind == "and" else AnyOf(*built)
        case _:
            known = (
                "circles_overlap, circle_meets_box, within, near, property_equals, "
                "property_above, property_below, property_in, and, or"
            )
            raise LocalProtocolError(f"unknown group definition type {kind!r} (known: {known})")
