"""Body size and nesting limits, checked before anything parses a request."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from dashboard.limits import MAX_BODY_BYTES, MAX_JSON_DEPTH, json_depth, shown
from tests.dashboard.conftest import TestClient

JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.text(alphabet='[]{}"\\ab'),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner),
    max_leaves=20,
)


def nesting(value: object) -> int:
    if isinstance(value, list):
        return 1 + max((nesting(v) for v in value), default=0)
    if isinstance(value, dict):
        return 1 + max((nesting(v) for v in value.values()), default=0)
    return 0


@pytest.mark.parametrize(
    ("text", "depth"),
    [
        ("1", 0),
        ("[]", 1),
        ('{"a": [1, {"b": []}]}', 4),
        ('"[[[[["', 0),
        ('["\\"[[["]', 1),
        ("[" * 3000, 3000),
        ("", 0),
    ],
)
def test_json_depth(text: str, depth: int) -> None:
    assert json_depth(text) == depth
    assert json_depth(text.encode()) == depth


@given(JSON_VALUES)
def test_json_depth_matches_the_nesting_of_any_value(value: object) -> None:
    assert json_depth(json.dumps(value)) == nesting(value)


def test_shown_cuts_long_values() -> None:
    assert shown("agv-1") == "'agv-1'"
    long = shown("x" * 1_000_000)
    assert len(long) < 120
    assert long.endswith("(1000002 characters)")


def test_a_body_over_the_limit_is_413(client: TestClient) -> None:
    body = {"station": "x" * MAX_BODY_BYTES}
    r = client.post("/api/tasks", json=body)
    assert r.status_code == 413
    assert r.json() == {"detail": f"request body over {MAX_BODY_BYTES} bytes"}


def test_a_body_nested_too_deeply_is_422(client: TestClient) -> None:
    r = client.post(
        "/api/tasks",
        content=b"[" * (MAX_JSON_DEPTH + 1) + b"]" * (MAX_JSON_DEPTH + 1),
        headers={"content-type": "application/json"},
    )
    assert r.status_code == 422
    assert r.json()["detail"] == (
        f"JSON body nests {MAX_JSON_DEPTH + 1} levels deep; at most {MAX_JSON_DEPTH} allowed"
    )


def test_a_body_within_the_limits_reaches_the_route(client: TestClient) -> None:
    r = client.post("/api/tasks", json={"station": "pick-A1-1"})
    assert r.status_code == 201
