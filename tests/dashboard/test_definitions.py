"""Group definitions as the API accepts them: strict, bounded, the middleware's JSON form."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import ValidationError

from dashboard.definitions import (
    MAX_DEFINITION_LEVELS,
    MAX_DEFINITION_PARTS,
    MAX_DISTANCE_M,
    definition_adapter,
)
from objectplaces import groups

NAMES = st.text(min_size=1, max_size=12)
LEAVES = st.one_of(
    st.builds(lambda d: {"type": "within", "distance": d}, st.floats(0.001, MAX_DISTANCE_M)),
    st.builds(lambda p, r: {"type": "circles_overlap", "position": p, "radius": r}, NAMES, NAMES),
    st.builds(
        lambda n, v: {"type": "property_equals", "name": n, "value": v},
        NAMES,
        st.none() | st.booleans() | st.integers(-(2**63), 2**63 - 1) | st.text(max_size=20),
    ),
)
DEFINITIONS = st.recursive(
    LEAVES,
    lambda inner: st.builds(
        lambda kind, parts: {"type": kind, "of": parts},
        st.sampled_from(["and", "or"]),
        st.lists(inner, min_size=1, max_size=3),
    ),
    max_leaves=12,
)


def nested(levels: int) -> dict[str, Any]:
    definition: dict[str, Any] = {"type": "within", "distance": 5.0}
    for _ in range(levels - 1):
        definition = {"type": "and", "of": [definition]}
    return definition


def error_of(raw: Any) -> str:
    with pytest.raises(ValidationError) as caught:
        definition_adapter.validate_python(raw)
    return "; ".join(e["msg"] for e in caught.value.errors())


@given(DEFINITIONS)
def test_a_valid_definition_builds_what_the_middleware_builds(raw: dict[str, Any]) -> None:
    built = definition_adapter.validate_python(raw).build()
    assert built == groups.definition_from_json(raw)
    assert definition_adapter.validate_python(built.to_json()).build() == built


@pytest.mark.parametrize(
    ("raw", "needle"),
    [
        ({"type": "within", "distance": 1.797e308}, "less than or equal to 100000"),
        ({"type": "within", "distance": 10**400}, "valid number"),
        ({"type": "within", "distance": float("inf")}, "finite number"),
        ({"type": "within", "distance": True}, "valid number"),
        ({"type": "within", "distance": "2"}, "valid number"),
        ({"type": "within", "distance": 0}, "greater than 0"),
        ({"type": "within", "distance": -1}, "greater than 0"),
        ({"type": "within"}, "group definition 'within' needs a 'distance'"),
        ({"type": "square"}, "unknown group definition type 'square'"),
        ({"type": "x" * 10_000}, "characters)"),
        ([1, 2], "a group definition is a JSON object, got [1, 2]"),
        ({"type": "circles_overlap", "radius": ""}, "at least 1 character"),
        ({"type": "circles_overlap", "radius": "r" * 129}, "at most 128 characters"),
        ({"type": "circles_overlap", "colour": "red"}, "Extra inputs are not permitted"),
        ({"type": "property_equals", "name": "status", "value": [1]}, "valid"),
        ({"type": "property_equals", "name": "status", "value": "v" * 1025}, "at most 1024"),
        ({"type": "and", "of": []}, "at least 1 item"),
        ({"type": "or", "of": {"type": "within", "distance": 1}}, "valid list"),
    ],
)
def test_bad_definitions_say_what_is_wrong(raw: Any, needle: str) -> None:
    assert needle in error_of(raw)


def test_nesting_is_bounded() -> None:
    assert definition_adapter.validate_python(nested(MAX_DEFINITION_LEVELS)).build()
    message = error_of(nested(MAX_DEFINITION_LEVELS + 1))
    assert f"at most {MAX_DEFINITION_LEVELS} levels" in message
    assert "at most" in error_of(nested(5000))  # refused before anything recurses


def test_parts_are_bounded() -> None:
    leaf = {"type": "circles_overlap"}
    wide = {"type": "or", "of": [leaf] * (MAX_DEFINITION_PARTS - 1)}
    assert definition_adapter.validate_python(wide).build()
    wider = {"type": "or", "of": [leaf] * MAX_DEFINITION_PARTS}
    assert f"hold at most {MAX_DEFINITION_PARTS} parts" in error_of(wider)
