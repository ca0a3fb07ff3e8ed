"""Where an AGV may rest: never on a two-way path it could meet someone head-on on."""

from __future__ import annotations

from agv_app.layout import Layout, Point, Segment
from agv_app.layout.demo import demo_warehouse
from agv_app.traffic.deadlock import DEFAULT_CLEARANCE_M, StopPlan, clearance_for


def corridor() -> Layout:
    pts = [Point("a", 0, 0), Point("b", 10, 0), Point("c", 20, 0), Point("d", 30, 0)]
    segs = [
        Segment("ab", "a", "b"),
        Segment("bc", "b", "c", bidirectional=True),
        Segment("cd", "c", "d"),
    ]
    return Layout(pts, segs)


def test_clearance_of_the_demo_vehicle() -> None:
    assert abs(DEFAULT_CLEARANCE_M - (1.0 + 5**0.5 / 2 + 0.15)) < 1e-12
    assert clearance_for(2.0, 1.0, margin_m=0.0) < DEFAULT_CLEARANCE_M


def test_no_rest_on_or_near_a_two_way_segment() -> None:
    layout = corridor()
    plan = StopPlan.for_route(layout, layout.route("a", "d"), clearance_m=2.0)
    assert plan.zones == ((8.0, 22.0),)
    assert plan.may_rest(7.9)
    assert not plan.may_rest(10.0)
    assert not plan.may_rest(21.9)
    assert plan.may_rest(30.0)


def test_a_request_reaching_into_the_run_covers_all_of_it() -> None:
    layout = corridor()
    plan = StopPlan.for_route(layout, layout.route("a", "d"), clearance_m=2.0)
    assert plan.next_stop(0.0, 5.0) == 5.0
    assert plan.next_stop(5.0, 5.0) == 22.0  # from a clear place to a clear place
    assert plan.next_stop(22.0, 5.0) == 27.0
    assert plan.next_stop(24.5, 5.0) == 30.0  # a sliver before the end goes to the end


def test_a_request_covers_at_least_the_passing_extent_between_two_demo_spurs() -> None:
    layout = demo_warehouse()
    # From one parking spur across the one-way S lane into the next: two two-way runs
    # whose no-rest zones meet, so the whole trip is one request.
    route = layout.route("S0350n", "S0475n")
    plan = StopPlan.for_route(layout, route, clearance_m=DEFAULT_CLEARANCE_M)
    for i, seg in enumerate(route.segments):
        if layout.segment(seg).bidirectional:
            extent = layout.passing_extent(route, i)
            assert not plan.may_rest(extent.s - 0.01)
    assert plan.next_stop(0.0, 5.0) == route.length
