"""A layout document with any value anywhere: it loads as a layout on the floor, or it
is refused with a ``LayoutFileError`` that says where; nothing else escapes the loader."""

from __future__ import annotations

import copy
import math
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from agv_app.layout import LayoutFileError
from agv_app.layout.graph import MAX_FLOOR_COORDINATE_M
from agv_app.layout.json_format import layout_from_json, layout_to_json
from tests.agv_app.layout.test_layout import GOOD

_SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
)
_VALUES = st.recursive(
    _SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=6,
)


def _paths(doc: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every path to a value of ``doc``, the document itself first."""
    found = [prefix]
    if isinstance(doc, dict):
        for key, value in doc.items():
            found += _paths(value, (*prefix, key))
    elif isinstance(doc, list):
        for index, value in enumerate(doc):
            found += _paths(value, (*prefix, index))
    return found


PATHS = _paths(GOOD)[1:]


@st.composite
def documents(draw: st.DrawFn) -> dict[str, Any]:
    """``GOOD`` with one to three values replaced, or keys removed."""
    doc = copy.deepcopy(GOOD)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(PATHS))
        parent: Any = doc
        try:
            for key in path[:-1]:
                parent = parent[key]
            if draw(st.booleans()) and isinstance(parent, dict):
                parent.pop(path[-1], None)
            else:
                parent[path[-1]] = draw(_VALUES)
        except (KeyError, IndexError, TypeError):
            continue  # an earlier change removed or replaced the way there
    return doc


@settings(max_examples=300, deadline=None)
@given(doc=documents())
def test_any_document_loads_onto_the_floor_or_is_refused_with_where(doc: dict[str, Any]) -> None:
    where = None
    try:
        layout = layout_from_json(doc)
    except LayoutFileError as exc:
        where = exc.where
    if where is not None:
        assert where.startswith("$"), where
        return
    for point in layout.points.values():
        for v in point.xy:
            assert math.isfinite(v), point
            assert abs(v) <= MAX_FLOOR_COORDINATE_M, point
    for seg in layout.segments.values():
        assert layout.segment_length(seg.id) > 0
    # What loaded writes out and loads again as the same layout.
    assert layout_to_json(layout_from_json(layout_to_json(layout))) == layout_to_json(layout)


COORDINATES = [p for p in PATHS if p[-1] in ("x", "y") or (len(p) == 5 and p[2] == "via")]


@settings(max_examples=200, deadline=None)
@given(
    path=st.sampled_from(COORDINATES),
    value=st.one_of(st.floats(), st.integers(min_value=-(10**400), max_value=10**400)),
)
def test_a_coordinate_loads_only_when_it_is_on_the_floor(
    path: tuple[Any, ...], value: float
) -> None:
    doc = copy.deepcopy(GOOD)
    parent: Any = doc
    for key in path[:-1]:
        parent = parent[key]
    parent[path[-1]] = value
    loaded = True
    try:
        layout_from_json(doc)
    except LayoutFileError:
        loaded = False
    if loaded:
        assert math.isfinite(value), (path, value)
        assert abs(value) <= MAX_FLOOR_COORDINATE_M, (path, value)
