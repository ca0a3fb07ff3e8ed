"""Merges without keep-clear boxes: no AGV rests where its turn blocks the lane it joins."""

from __future__ import annotations

from pathlib import Path

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout import Layout, Point, Segment, load_any
from agv_app.layout.demo import demo_warehouse
from agv_app.layout.generated import generated_warehouse
from agv_app.layout.loop import long_loop
from agv_app.traffic.deadlock import StopPlan, merge_branches
from tests.agv_app.vehicles import vehicle_with

DEMO_01 = Path(__file__).resolve().parents[3] / "agv_app/data/opentcs/Demo-01.xml"


def tee(*, box: bool = False) -> Layout:
    """A one-way lane west to east along y = 0, and a one-way branch from the north
    that turns into it at ``j`` (with a 1.5 m keep-clear box if ``box``); a parking
    spur off the lane at ``k``."""
    points = [
        Point("w", 0, 0),
        Point("j", 20, 0),
        Point("k", 30, 0),
        Point("e", 40, 0),
        Point("n", 20, 15),
        Point("pk", 30, -2.5),
    ]
    segments = [
        Segment("wj", "w", "j"),
        Segment("jk", "j", "k"),
        Segment("ke", "k", "e"),
        Segment("k-pk", "k", "pk", bidirectional=True),
    ]
    if box:
        points.append(Point("nb", 20, 1.5))
        segments += [Segment("n-nb", "n", "nb"), Segment("nb-j", "nb", "j", bidirectional=True)]
    else:
        segments.append(Segment("nj", "n", "j"))
    return Layout(points, segments)


def crossing() -> Layout:
    """Two one-way lanes crossing straight at ``x``."""
    points = [Point("w", 0, 0), Point("x", 10, 0), Point("e", 20, 0)]
    points += [Point("s", 10, -10), Point("n", 10, 10)]
    segments = [Segment("wx", "w", "x"), Segment("xe", "x", "e")]
    segments += [Segment("sx", "s", "x"), Segment("xn", "x", "n")]
    return Layout(points, segments)


def test_a_branch_turning_into_a_lane_is_a_merge_branch_and_the_lane_is_not() -> None:
    assert merge_branches(tee()) == {"nj"}


def test_a_branch_going_straight_into_a_dead_end_spur_still_turns_into_the_lane() -> None:
    # The generated warehouse: aisle A3 ends on the N lane at N02050, where a two-way
    # parking spur leaves straight ahead. The spur is no way on; an AGV resting at the
    # aisle's end with its front in the lane and one on the lane locked (seed 1, 100
    # AGVs, 3 m requests, after 18 minutes).
    layout = tee()
    spur = Layout(
        [*layout.points.values(), Point("js", 20, -2.5)],
        [*layout.segments.values(), Segment("j-js", "j", "js", bidirectional=True)],
    )
    assert merge_branches(spur) == {"nj"}
    assert "b1-A3-3>b1-N02050" in merge_branches(generated_warehouse(100))


def test_a_keep_clear_box_already_keeps_the_branch_clear() -> None:
    assert merge_branches(tee(box=True)) == frozenset()


def test_every_way_into_a_crossing_is_a_merge_branch() -> None:
    assert merge_branches(crossing()) == {"wx", "sx"}


@pytest.mark.parametrize(
    "layout", [demo_warehouse(), long_loop(300.0)], ids=["demo warehouse", "long loop"]
)
def test_floors_drawn_with_boxes_gain_no_zone(layout: Layout) -> None:
    assert merge_branches(layout) == frozenset()


def test_floors_drawn_without_boxes_have_merge_branches() -> None:
    assert merge_branches(generated_warehouse(12))
    assert merge_branches(load_any(DEMO_01))


def test_the_branch_ends_in_a_zone_like_a_box() -> None:
    layout = tee()
    route = layout.route("n", "e")
    plain = StopPlan.for_route(layout, route, clearance_m=2.0)
    plan = StopPlan.for_route(
        layout, route, clearance_m=2.0, merges=merge_branches(layout), merge_box_m=1.5
    )
    assert plain.zones == ()
    assert plan.zones == ((15.0 - 3.5, 15.0 + 2.0),)
    assert plan.next_stop(8.0, 5.0) == 17.0  # through the junction, turn included
    # The lane going straight on through the junction keeps every resting place.
    along = layout.route("w", "e")
    assert StopPlan.for_route(
        layout, along, clearance_m=2.0, merges=merge_branches(layout), merge_box_m=1.5
    ).may_rest(20.0)


# Each run is 400 simulated seconds of 12 AGVs (a few seconds of CPU).
@pytest.mark.slow
@pytest.mark.parametrize("seed", [5, 7])
def test_a_floor_without_boxes_no_longer_locks_at_its_merges(seed: int) -> None:
    """The generated warehouse has no keep-clear boxes. Before, an AGV came to rest
    where an aisle turns into the M lane, its hull still facing down the aisle; the AGV
    behind it on the lane pulled up into the room its turn needs, and each waited for
    the other (the whole fleet behind them stood). Without the merge rule seeds 1, 2,
    5, 6, 7 and 10 of 1-10 lock; with the turn-off rule alone (no AGV rests just past
    a turn off a lane, ``test_turn_offs.py``) seeds 5 and 7 still do (10 and 12 of 12
    AGVs over 180 s)."""
    layout = generated_warehouse(12)
    # As found: stations calling every winner at once, the queues at the docks the hard
    # case the rule must hold in, and no node at rest (it came later).
    config = FleetConfig(
        agvs=12,
        seed=seed,
        load=0.9,
        one_at_a_time=False,
        rest_beat=None,
        station_nodes=True,  # as found
        max_open_tasks=None,  # as found
        fail_on_violation=True,
    )
    locked = Fleet(layout, config, vehicle=vehicle_with(clear_merges=False))
    locked.run(400.0)
    assert locked.summary()["deadlocks"] > 0
    fleet = Fleet(layout, config)
    fleet.run(400.0)
    figures = fleet.summary()
    assert figures["deadlocks"] == figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["tasks_completed"] > 2 * locked.summary()["tasks_completed"]
