"""Turns off a one-way lane: no AGV rests with the back of its hull still in the lane."""

from __future__ import annotations

from agv_app.layout import Layout, Point, Segment
from agv_app.layout.demo import demo_warehouse
from agv_app.traffic.deadlock import StopPlan, turn_offs


def fork(*, two_way_lane: bool = False) -> Layout:
    """A lane west to east along y = 0 (one-way unless ``two_way_lane``) and a one-way
    aisle that turns off it at ``j`` to the south, ending at ``s``."""
    points = [Point("w", 0, 0), Point("j", 20, 0), Point("e", 40, 0), Point("s", 20, -15)]
    segments = [
        Segment("wj", "w", "j", bidirectional=two_way_lane),
        Segment("je", "j", "e", bidirectional=two_way_lane),
        Segment("js", "j", "s"),
    ]
    return Layout(points, segments)


def test_the_aisle_turns_off_the_lane_and_the_lane_goes_on() -> None:
    assert turn_offs(fork()) == {("wj", "js")}


def test_a_two_way_lane_needs_no_turn_off_zone() -> None:
    assert turn_offs(fork(two_way_lane=True)) == frozenset()


def test_a_bend_with_no_way_straight_on_is_no_turn_off() -> None:
    points = [Point("w", 0, 0), Point("j", 20, 0), Point("s", 20, -15)]
    assert turn_offs(Layout(points, [Segment("wj", "w", "j"), Segment("js", "j", "s")])) == (
        frozenset()
    )


def test_the_aisle_starts_in_a_zone_as_long_as_the_clearance() -> None:
    layout = fork()
    route = layout.route("w", "s")
    plain = StopPlan.for_route(layout, route, clearance_m=2.0)
    plan = StopPlan.for_route(layout, route, clearance_m=2.0, turns=turn_offs(layout))
    assert plain.zones == ()
    assert plan.zones == ((20.0, 22.0),)
    assert plan.may_rest(20.0)
    assert not plan.may_rest(21.0)
    assert plan.may_rest(22.0)
    assert plan.next_stop(16.0, 5.0) == 22.0  # clear of the lane, not in the turn
    # The lane straight on past the junction keeps every resting place.
    along = layout.route("w", "e")
    assert StopPlan.for_route(layout, along, clearance_m=2.0, turns=turn_offs(layout)).zones == ()


def test_the_demo_warehouse_turns_off_its_main_lanes_into_the_aisles() -> None:
    """Every aisle of the demo warehouse leaves lane M or N by a one-way turn; the
    turns into two-way pieces (parking spurs, station boxes) are there too, their
    zones reaching the clearance beyond them already."""
    layout = demo_warehouse()
    one_way = {out for _, out in turn_offs(layout) if not layout.segment(out).bidirectional}
    aisles = {layout.segment(out).end.split("-")[0] for out in one_way}
    assert {f"A{k}" for k in range(1, 9)} <= aisles
