"""An AGV bound for a station never rests on the way the AGV standing there leaves by."""

from __future__ import annotations

import itertools

import pytest

from agv_app.layout import Layout, load_any
from agv_app.layout.builder import LayoutBuilder
from agv_app.layout.demo import demo_warehouse
from agv_app.traffic.deadlock import DEFAULT_CLEARANCE_M, StopPlan, way_out
from tests.agv_app.traffic.test_deadlock import corridor
from tests.agv_app.traffic.test_merges import DEMO_01


def ring_with_aisles(*, connector: bool = False) -> Layout:
    """A one-way ring 40 m by 20 m (south lane east, north lane west), an aisle south
    at x = 10 and one north at x = 15 with a dock spur east off it at ``a2``, 4 m below
    the north lane, and a parking spur north off the north lane at ``n3``; with
    ``connector``, a one-way lane east from ``a1`` on the first aisle to ``a2``."""
    b = LayoutBuilder()
    for pid, x, y in [
        ("sw", 0, 0), ("s1", 10, 0), ("s2", 15, 0), ("se", 40, 0),
        ("ne", 40, 20), ("n3", 30, 20), ("n2", 15, 20), ("n1", 10, 20), ("nw", 0, 20),
        ("a1", 10, 16), ("a2", 15, 16), ("a2x", 17.5, 16), ("p3", 30, 22.5),
    ]:  # fmt: skip
        b.point(pid, x, y)
    b.chain(["sw", "s1", "s2", "se", "ne", "n3", "n2", "n1", "nw", "sw"])
    b.chain(["n1", "a1", "s1"])
    b.chain(["s2", "a2", "n2"])
    if connector:
        b.chain(["a1", "a2"])
    b.spur("a2", "a2x", "dock", "pickdrop")
    b.spur("n3", "p3", "park", "parking")
    return Layout(b.points, b.segments, b.stations)


def test_the_way_out_of_a_dock_runs_to_the_first_point_with_a_choice() -> None:
    # Out of the dock, up the aisle, west along the north lane: at n1 an AGV may go on
    # west or down the other aisle.
    assert way_out(ring_with_aisles(), "a2x") == {"a2>a2x", "a2>n2", "n2>n1"}


def test_a_point_with_two_ways_on_has_no_way_out() -> None:
    assert way_out(ring_with_aisles(), "n3") == frozenset()  # on west, or into the spur


def test_a_way_out_through_two_way_and_one_way_segments_ends_at_a_dead_end() -> None:
    assert way_out(corridor(), "b") == {"bc", "cd"}
    assert way_out(corridor(), "d") == frozenset()


def test_a_ring_without_a_choice_is_one_way_out_and_the_trace_ends() -> None:
    b = LayoutBuilder()
    for pid, x, y in [("a", 0, 0), ("b", 10, 0), ("c", 10, 10), ("d", 0, 10)]:
        b.point(pid, x, y)
    b.chain(["a", "b", "c", "d", "a"])
    # The way back into ``a`` is not on it: an AGV waiting there queues behind.
    assert way_out(Layout(b.points, b.segments), "a") == {"a>b", "b>c", "c>d"}


def test_a_route_that_comes_along_the_way_out_just_before_the_dock_may_not_rest_on_it() -> None:
    layout = ring_with_aisles(connector=True)
    # Out of the parking spur, west along the north lane over the dock's way out, down
    # the first aisle and east along the connector to the dock.
    route = layout.route("p3", "a2x")
    assert route.points == ("p3", "n3", "n2", "n1", "a1", "a2", "a2x")
    plain = StopPlan.for_route(layout, route, clearance_m=2.0)
    plan = StopPlan.for_route(layout, route, clearance_m=2.0, way_out_reach_m=5.0)
    n2, n1, a2 = route.offsets[2], route.offsets[3], route.offsets[5]
    assert plain.zones == ((-2.0, 4.5), (a2 - 2.0, 36.0))
    # A request from n2 - n1 would reach the dock's spur (29.5 m) with 5 m and a
    # quarter, and the clearance, to spare: there it would wait for the dock's AGV.
    assert plan.zones == ((-2.0, 4.5), (n2 - 2.0, n1 + 2.0), (a2 - 2.0, 36.0))
    # It waits east of the way out, where the docked AGV turns in ahead of it, or past
    # n1, where the docked AGV may go on west instead.
    assert plan.may_rest(n2 - 2.0)
    assert not plan.may_rest(n2)
    assert not plan.may_rest(n1 + 1.9)
    assert plan.may_rest(n1 + 2.0)
    assert plan.next_stop(n2 - 4.0, 5.0) == n1 + 2.0


def test_a_way_out_far_from_the_destination_along_the_route_stays_a_resting_place() -> None:
    layout = ring_with_aisles()
    # West over the dock's way out, then the long way round: down the first aisle,
    # east along the south lane, up the dock's aisle. From the north lane no request
    # reaches the dock, so no AGV waits for it there.
    route = layout.route("p3", "a2x")
    assert route.points == ("p3", "n3", "n2", "n1", "a1", "s1", "s2", "a2", "a2x")
    plain = StopPlan.for_route(layout, route, clearance_m=2.0)
    plan = StopPlan.for_route(layout, route, clearance_m=2.0, way_out_reach_m=5.0)
    assert plan.zones == plain.zones


@pytest.mark.parametrize(
    "layout", [demo_warehouse(), load_any(DEMO_01)], ids=["demo warehouse", "openTCS Demo-01"]
)
def test_floors_whose_ways_out_lead_away_gain_no_zone(layout: Layout) -> None:
    """No route between two stations of these floors comes along its destination's way
    out within a request's reach of it, so their fleets drive as before."""
    points = sorted({station.point for station in layout.stations.values()})
    for a, b in itertools.permutations(points, 2):
        route = layout.route(a, b)
        plain = StopPlan.for_route(layout, route, clearance_m=DEFAULT_CLEARANCE_M)
        plan = StopPlan.for_route(
            layout, route, clearance_m=DEFAULT_CLEARANCE_M, way_out_reach_m=5.0
        )
        assert plan.zones == plain.zones, (a, b)
