"""Group definitions: evaluation, JSON form, reach, and the spatial index behind them."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from objectplaces import LocalProtocolError, groups
from objectplaces.core.spatial import GridIndex, RunningMax
from objectplaces.core.view_index import ViewIndex


def props(x: float, y: float, r: float = 1.0, **extra: object) -> dict[str, object]:
    return {"position": (x, y), "hull_length": r, **extra}


def test_circles_overlap_is_the_papers_collision_range() -> None:
    defn = groups.circles_overlap()
    assert defn(props(0, 0, 2), props(4, 0, 2))
    assert not defn(props(0, 0, 2), props(4.01, 0, 2))
    assert not defn(props(0, 0, 2), {"hull_length": 5})
    assert defn(props(0, 0, 2), {"position": (1, 0)})  # a missing radius counts as 0


def test_circle_meets_box_asks_only_the_candidates_circle() -> None:
    defn = groups.circle_meets_box((0, 0, 10, 2))
    anyone = props(100, 100, 0)  # the initiator's own circle plays no part
    assert defn(anyone, props(5, 3, 1))  # above the box, touching it
    assert not defn(anyone, props(5, 3.01, 1))
    assert defn(anyone, props(13, 6, 5))  # beyond a corner: 3-4-5
    assert not defn(anyone, props(13, 6, 4.99))
    assert defn(anyone, props(4, 1, 0))  # inside, radius 0
    assert not defn(anyone, {"hull_length": 50})  # no position


def test_within_and_property_equals_and_combinations() -> None:
    near_idle = groups.within(5.0) & groups.property_equals("status", "idle")
    assert near_idle(props(0, 0), props(3, 4, status="idle"))
    assert not near_idle(props(0, 0), props(3, 4, status="busy"))
    assert not near_idle(props(0, 0), props(3, 4.1, status="idle"))
    either = groups.within(1.0) | groups.property_equals("kind", "station")
    assert either(props(0, 0), props(50, 50, kind="station"))
    assert not either(props(0, 0), props(50, 50))


def test_near_asks_only_the_candidates_distance_to_its_point() -> None:
    defn = groups.near((10, 0), 5.0)
    for initiator in (props(100, 100), {}):  # wherever the initiator is, if anywhere
        assert defn(initiator, props(13, 4))  # 3-4-5
        assert not defn(initiator, props(13, 4.01))
        assert not defn(initiator, {"hull_length": 1})  # no position
    assert groups.near((0, 0), 1, position="pos")({}, {"pos": (0.5, 0.5)})
    with pytest.raises(LocalProtocolError, match="two numbers"):
        groups.near((0, float("inf")), 1)


def test_a_node_without_a_position_finds_the_candidates_near_a_point() -> None:
    view = {f"n{i}": props(float(i), 0.0) for i in range(100)}
    index = ViewIndex(view, cell_size=5.0)
    defn = groups.near((50, 0), 2.0) & groups.property_equals("hull_length", 1.0)
    candidates = set(index.candidates(defn, {}))
    assert {"n48", "n49", "n50", "n51", "n52"} <= candidates
    assert len(candidates) < 40  # the grid's cells about the point, not the whole view
    assert {n for n in candidates if defn({}, view[n])} == {"n48", "n49", "n50", "n51", "n52"}


@pytest.mark.parametrize(
    "defn",
    [
        groups.near((3.0, -4.0), 10.0),
        groups.near((1, 2), 5, position="pos") & groups.property_equals("status", "idle"),
        groups.circles_overlap(),
        groups.circles_overlap(position="pos", radius="r"),
        groups.within(12.5),
        groups.property_equals("status", "idle"),
        groups.within(3) & groups.property_equals("status", "idle"),
        groups.within(3) | groups.circles_overlap(),
        groups.circle_meets_box((0.0, -1.5, 12.0, 2.0)),
        groups.circle_meets_box((1, 2, 3, 4), position="pos", radius="r")
        & groups.property_equals("kind", "agv"),
        groups.property_above("battery", 50),
        groups.property_below("load_kg", 12.5),
        groups.property_in("status", ["idle", "charging"]),
        groups.within(40) & (groups.property_above("battery", 50) | groups.property_in("k", [1])),
    ],
)
def test_json_round_trip(defn: groups.GroupDefinition) -> None:
    again = groups.definition_from_json(defn.to_json())
    assert again == defn
    assert again.to_json() == defn.to_json()


@pytest.mark.parametrize(
    ("obj", "reason"),
    [
        ([1, 2], "is a JSON object"),
        ({"type": "nearest"}, "unknown group definition type 'nearest'"),
        ({"type": "within"}, "needs a 'distance'"),
        ({"type": "within", "distance": -1}, "finite number >= 0"),
        ({"type": "within", "distance": "1"}, "within: distance must be a finite number >= 0"),
        ({"type": "near", "point": [0, 0], "distance": None}, "near: distance must be"),
        ({"type": "near", "distance": 1}, "needs a 'point' and a 'distance'"),
        ({"type": "near", "point": [0, 0]}, "needs a 'point' and a 'distance'"),
        ({"type": "near", "point": [0], "distance": 1}, "two numbers"),
        ({"type": "near", "point": [0, "1"], "distance": 1}, "two numbers"),
        ({"type": "near", "point": [0, 0], "distance": math.nan}, "finite number >= 0"),
        ({"type": "property_equals", "name": "x"}, "needs a 'value'"),
        ({"type": "property_above", "name": "x"}, "needs a 'value'"),
        ({"type": "property_below", "name": "x", "value": "3"}, "must be a finite number"),
        ({"type": "property_above", "name": "x", "value": True}, "must be a finite number"),
        ({"type": "property_above", "name": "x", "value": math.inf}, "finite number"),
        ({"type": "property_above", "value": 3}, "non-empty string"),
        ({"type": "property_in", "name": "x", "values": "ab"}, "needs a list 'values'"),
        ({"type": "property_in", "name": "x"}, "needs a list 'values'"),
        ({"type": "and", "of": []}, "non-empty list 'of'"),
        ({"type": "circles_overlap", "position": 3}, "non-empty string"),
        ({"type": "circle_meets_box"}, "box must be four numbers within"),
        ({"type": "circle_meets_box", "box": [0, 0, 1]}, "box must be four numbers within"),
        ({"type": "circle_meets_box", "box": [2, 0, 1, 1]}, "x0 <= x1"),
        ({"type": "circle_meets_box", "box": [0, 0, 1, float("nan")]}, "four numbers within"),
        ({"type": "circle_meets_box", "box": [0, 0, 1, "1"]}, "four numbers within"),
        ({"type": "circle_meets_box", "box": [0, 0, 1, 1.7e308]}, r"within \+-1e\+12"),
    ],
)
def test_invalid_json_is_refused_clearly(obj: object, reason: str) -> None:
    with pytest.raises(LocalProtocolError, match=reason):
        groups.definition_from_json(obj)


def test_reach_bounds_candidates() -> None:
    def max_of(name: str) -> float:
        return 3.0

    assert groups.circles_overlap().reach(props(0, 0, 2), max_of).radius == 5.0  # type: ignore[union-attr]
    assert groups.within(7).reach(props(0, 0), max_of).radius == 7.0  # type: ignore[union-attr]
    assert groups.property_equals("a", 1).reach(props(0, 0), max_of) is None
    both = groups.within(7) & groups.property_equals("a", 1)
    assert both.reach(props(0, 0), max_of).radius == 7.0  # type: ignore[union-attr]
    assert (groups.within(7) | groups.property_equals("a", 1)).reach(props(0, 0), max_of) is None
    assert (groups.within(7) | groups.within(9)).reach(props(0, 0), max_of).radius == 9.0  # type: ignore[union-attr]
    at_point = groups.near((5, 5), 7).reach({}, max_of)
    assert at_point is not None
    assert (at_point.centre, at_point.radius) == ((5.0, 5.0), 7.0)
    same = groups.near((5, 5), 7) | groups.near((5, 5), 9)
    assert same.reach({}, max_of).radius == 9.0  # type: ignore[union-attr]
    # About two points, or a point and the initiator: no one bound holds both.
    assert (groups.near((5, 5), 7) | groups.near((0, 0), 9)).reach({}, max_of) is None
    assert (groups.near((5, 5), 7) | groups.within(9)).reach(props(5, 5), max_of) is None


points = st.lists(st.tuples(st.floats(-100, 100), st.floats(-100, 100)), min_size=0, max_size=40)
coordinate = st.floats(-100, 100)


@given(
    own=st.tuples(coordinate, coordinate),
    corners=st.tuples(coordinate, coordinate, coordinate, coordinate),
    members=st.lists(st.tuples(coordinate, coordinate, st.floats(0, 30)), max_size=20),
)
def test_the_box_reach_holds_every_member(
    own: tuple[float, float],
    corners: tuple[float, float, float, float],
    members: list[tuple[float, float, float]],
) -> None:
    xa, ya, xb, yb = corners
    defn = groups.circle_meets_box((min(xa, xb), min(ya, yb), max(xa, xb), max(ya, yb)))
    largest = max((r for _, _, r in members), default=0.0)
    reach = defn.reach(props(*own), lambda name: largest)
    assert reach is not None
    for x, y, r in members:
        if defn({}, props(x, y, r)):
            assert math.dist((x, y), own) <= reach.radius + 1e-9


@given(
    view=st.lists(st.tuples(coordinate, coordinate), max_size=40),
    point=st.tuples(coordinate, coordinate),
    distance=st.floats(0, 80),
    cell=st.sampled_from([1.0, 7.5, 25.0]),
    own=st.one_of(st.none(), st.tuples(coordinate, coordinate)),
)
def test_the_index_finds_every_member_near_a_point(
    view: list[tuple[float, float]],
    point: tuple[float, float],
    distance: float,
    cell: float,
    own: tuple[float, float] | None,
) -> None:
    nodes = {f"n{i}": props(x, y) for i, (x, y) in enumerate(view)}
    defn = groups.near(point, distance)
    initiator = {} if own is None else props(*own)  # where the initiator is plays no part
    members = {n for n, p in nodes.items() if defn(initiator, p)}
    assert members <= set(ViewIndex(nodes, cell).candidates(defn, initiator))


@given(
    points=points,
    centre=st.tuples(st.floats(-100, 100), st.floats(-100, 100)),
    radius=st.floats(0, 80),
    cell=st.sampled_from([1.0, 7.5, 25.0]),
)
def test_grid_index_never_misses_a_node_in_range(
    points: list[tuple[float, float]], centre: tuple[float, float], radius: float, cell: float
) -> None:
    index = GridIndex(cell)
    for i, (x, y) in enumerate(points):
        index.place(f"n{i}", x, y)
    for i, (x, y) in enumerate(points[::2]):
        index.place(f"n{2 * i}", y, x)  # moves keep the index consistent
    where = {f"n{i}": p for i, p in enumerate(points)}
    for i, (x, y) in enumerate(points[::2]):
        where[f"n{2 * i}"] = (y, x)
    found = set(index.near(*centre, radius))
    within = {n for n, (x, y) in where.items() if math.dist((x, y), centre) <= radius}
    assert within <= found
    assert len(index) == len(where)


def test_grid_index_remove_and_infinite_reach() -> None:
    index = GridIndex(10.0)
    index.place("a", 0, 0)
    index.place("b", 500, 500)
    assert set(index.near(0, 0, math.inf)) == {"a", "b"}
    index.remove("b")
    index.remove("unknown")
    assert set(index.near(0, 0, 1000)) == {"a"}
    with pytest.raises(ValueError, match="cell_size"):
        GridIndex(0)


def test_running_max_follows_increases_and_decreases() -> None:
    running = RunningMax()
    assert running.value == 0.0
    running.set("a", 3.0)
    running.set("b", 5.0)
    assert running.value == 5.0
    running.set("b", 1.0)
    assert running.value == 3.0
    running.remove("a")
    assert running.value == 1.0
