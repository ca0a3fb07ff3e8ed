"""The group definitions' written-out tests, and a group decided in one pass, against
their plain forms."""

from __future__ import annotations

import math
from typing import Any

from hypothesis import example, given
from hypothesis import strategies as st

from objectplaces import groups
from objectplaces.core.config import NodeConfig
from objectplaces.core.messages import PropertyUpdate
from objectplaces.core.observers import Observers
from objectplaces.core.plumbing import Plumbing
from objectplaces.core.view import PropertyView

NUMBERS = (
    st.floats(-50.0, 50.0)
    | st.integers(-50, 50)
    | st.booleans()
    | st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0])
)
VALUES: Any = NUMBERS | st.none() | st.text(max_size=2)
POSITIONS: Any = (
    st.tuples(NUMBERS, NUMBERS)
    | st.lists(NUMBERS, min_size=1, max_size=3)
    | st.tuples(VALUES, VALUES)
    | VALUES
)
PROPS = st.fixed_dictionaries({}, optional={"position": POSITIONS, "hull_length": VALUES})


def plain_circle_meets_box(box: tuple[float, float, float, float], props: Any) -> bool:
    """The definition as the paper's geometry states it, with the library's own helpers."""
    value = props.get("position")
    if not (isinstance(value, tuple | list) and len(value) == 2):
        return False
    if not all(isinstance(v, int | float) for v in value):
        return False
    px, py = float(value[0]), float(value[1])
    radius = props.get("hull_length", 0.0)
    r = float(radius) if isinstance(radius, int | float) else 0.0
    x0, y0, x1, y1 = box
    dx = max(x0 - px, 0.0, px - x1)
    dy = max(y0 - py, 0.0, py - y1)
    return dx * dx + dy * dy <= r * r


@given(
    corner=st.tuples(st.floats(-40.0, 40.0), st.floats(-40.0, 40.0)),
    size=st.tuples(st.floats(0.0, 20.0), st.floats(0.0, 20.0)),
    props=PROPS,
)
@example(
    corner=(10.0, 10.0), size=(4.0, 2.0), props={"position": (math.nan, 11.0), "hull_length": 5}
)
@example(corner=(10.0, 10.0), size=(4.0, 2.0), props={"position": (11, math.nan), "hull_length": 5})
@example(corner=(10.0, 10.0), size=(4.0, 2.0), props={"position": [10, 12.0], "hull_length": True})
def test_circle_meets_box_decides_as_its_plain_definition(
    corner: tuple[float, float], size: tuple[float, float], props: dict[str, Any]
) -> None:
    box = (corner[0], corner[1], corner[0] + size[0], corner[1] + size[1])
    assert groups.circle_meets_box(box)({}, props) is plain_circle_meets_box(box, props)


@given(
    flags=st.lists(st.booleans(), min_size=1, max_size=4),
    kind=st.sampled_from(["agv", "station", None]),
)
def test_all_of_is_every_part_and_stops_at_the_first_no(
    flags: list[bool], kind: str | None
) -> None:
    asked: list[int] = []

    class Part(groups.GroupDefinition):
        def __init__(self, i: int) -> None:
            self.i = i

        def __call__(self, initiator: Any, participant: Any) -> bool:
            asked.append(self.i)
            return flags[self.i]

        def to_json(self) -> dict[str, Any]:
            return {"type": "part", "i": self.i}

    definition = groups.AllOf(*(Part(i) for i in range(len(flags))))
    props = {} if kind is None else {"kind": kind}
    assert definition({}, props) is all(flags)
    assert asked == list(range(flags.index(False) + 1 if False in flags else len(flags)))


@given(
    nodes=st.lists(
        st.tuples(st.sampled_from("abcdef"), st.integers(0, 3)), unique_by=lambda t: t[0]
    ),
    asked=st.lists(st.sampled_from("abcdefg"), unique=True),
    raising=st.sets(st.integers(0, 3), max_size=1),
)
def test_matching_in_one_pass_is_matches_node_by_node(
    nodes: list[tuple[str, int]], asked: list[str], raising: set[int]
) -> None:
    def plumbing_and_view() -> tuple[Plumbing, PropertyView]:
        plumbing = Plumbing.build("me", NodeConfig(cell_size=10.0))
        v = PropertyView(plumbing, observers=Observers(plumbing.outbox))
        for i, (node, level) in enumerate(nodes):
            v.apply(node, PropertyUpdate(i + 1, {"level": level}), now=0.0)
        return plumbing, v

    def definition(own: Any, props: Any) -> bool:
        if props["level"] in raising:
            raise RuntimeError("a broken definition")
        return bool(props["level"] >= 2)

    plumbing, v = plumbing_and_view()
    plain_plumbing, plain = plumbing_and_view()
    one_pass = v.matching(definition, {}, asked, "s")
    node_by_node = {n for n in asked if plain.matches(definition, {}, n, "s")}
    assert one_pass == node_by_node
    assert plumbing.outbox.counters == plain_plumbing.outbox.counters
