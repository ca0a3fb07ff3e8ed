"""Capacity: same-direction AGVs follow each other through a two-way run they drive
through, holding direction claims; the opposite direction waits (docs/traffic.md)."""

from __future__ import annotations

import itertools

import shapely

from agv_app.fleet import Fleet, FleetConfig
from agv_app.geometry import Area
from agv_app.layout import Layout, Point, Segment, Station
from agv_app.layout.demo import demo_warehouse
from agv_app.traffic import LockBook, LockEntry, RequestEntry, decide_vote
from agv_app.traffic.deadlock import (
    DEFAULT_CLEARANCE_M,
    StopPlan,
    claims_conflict,
    followable_segments,
)
from tests.agv_app.two_way_floors import two_docks_one_lane
from tuplespace import TupleSpace

CORRIDOR = frozenset({"W-c1", "c1-c2", "c2-c3", "c3-E"})


def corridor_loops(corridor_m: float = 40.0) -> Layout:
    """Two one-way loops that share a two-way corridor W <-> E (y = 0).

    North lane westbound (E -> NE -> NW -> W), south lane eastbound (W -> SW -> SE -> E);
    docks and parking on two-way spurs off both lanes. From the west of the north lane
    to its east the corridor is the short way, W to E; from the east of the south lane
    to its west, E to W: the corridor is driven both ways.
    """
    step = corridor_m / 4
    pts = [Point("W", 0, 0), Point("E", corridor_m, 0)]
    pts += [Point(f"c{i}", i * step, 0) for i in (1, 2, 3)]
    pts += [Point("NE", corridor_m, 15), Point("NW", 0, 15)]
    pts += [Point("SW", 0, -15), Point("SE", corridor_m, -15)]
    corridor = ["W", "c1", "c2", "c3", "E"]
    segs = [Segment(f"{a}-{b}", a, b, bidirectional=True) for a, b in itertools.pairwise(corridor)]
    xs = [corridor_m * f for f in (0.875, 0.625, 0.375, 0.125)]
    for k, x in enumerate(xs):
        for lane, y in (("N", 15), ("S", -15)):
            pts += [
                Point(f"{lane}{k}", x, y),
                Point(f"{lane.lower()}{k}", x, y + (5 if y > 0 else -5)),
            ]
            segs.append(
                Segment(f"{lane}{k}-spur", f"{lane}{k}", f"{lane.lower()}{k}", bidirectional=True)
            )
    north = ["E", "NE", "N0", "N1", "N2", "N3", "NW", "W"]
    south = ["W", "SW", "S3", "S2", "S1", "S0", "SE", "E"]
    for chain in (north, south):
        segs += [Segment(f"{a}>{b}", a, b) for a, b in itertools.pairwise(chain)]
    stations = [
        Station("n-east", "n0", "pickdrop"),
        Station("n-west", "n3", "pickdrop"),
        Station("s-east", "s0", "pickdrop"),
        Station("s-west", "s3", "pickdrop"),
    ]
    stations += [Station(f"park-{p}", p, "parking") for p in ("n1", "n2", "s1", "s2")]
    return Layout(pts, segs, stations, name="corridor-loops")


def test_claims_conflict_unless_both_drive_through_the_same_way() -> None:
    assert not claims_conflict({("a", 1)}, {("a", 1)})
    assert claims_conflict({("a", 1)}, {("a", -1)})
    assert claims_conflict({("a", 1)}, {("a", 0)})
    assert claims_conflict({("a", 0)}, {("a", 0)})
    assert not claims_conflict({("a", 1)}, {("b", -1)})


def test_only_runs_with_a_way_in_and_a_way_out_are_followable() -> None:
    assert followable_segments(corridor_loops()) == CORRIDOR
    assert followable_segments(two_docks_one_lane()) == frozenset()


def test_a_route_through_the_corridor_may_wait_inside_it_only_when_following() -> None:
    layout = corridor_loops()
    route = layout.route("n3", "n0")
    plan = StopPlan.for_route(
        layout,
        route,
        clearance_m=DEFAULT_CLEARANCE_M,
        followable=followable_segments(layout),
    )
    (lo, hi), through = plan.zones[1], plan.through[1]
    assert through
    assert plan.claims[1] == tuple((seg, 1) for seg in ("W-c1", "c1-c2", "c2-c3", "c3-E"))
    assert plan.next_stop(lo, 5.0) == hi  # the whole passage, as before
    stop = plan.next_stop(lo, 5.0, follow=True)
    assert lo + 2 * DEFAULT_CLEARANCE_M < stop < hi - 2 * DEFAULT_CLEARANCE_M
    assert plan.claims_between(lo, stop) == frozenset(plan.claims[1])


def test_a_keep_clear_box_is_too_short_to_wait_in() -> None:
    layout = corridor_loops(corridor_m=4.0)
    route = layout.route("n3", "n0")
    plan = StopPlan.for_route(
        layout,
        route,
        clearance_m=DEFAULT_CLEARANCE_M,
        followable=followable_segments(layout),
    )
    k = next(i for i, claims in enumerate(plan.claims) if claims)
    lo, hi = plan.zones[k]
    assert plan.next_stop(lo, 1.0, follow=True) == hi


def test_a_lock_claiming_the_run_the_other_way_holds_the_request_up() -> None:
    book = LockBook(TupleSpace())
    far = Area(shapely.box(100, 0, 102, 1))
    book.set_locks(LockEntry(1, 0.0, Area(shapely.box(0, 0, 2, 1)), frozenset({("c1-c2", -1)})))
    circle = (101.0, 0.5, 3.0)  # the requester's, covering its request
    assert decide_vote(far, (1.0, "r"), book, circle, claims=frozenset({("c1-c2", -1)})) == (
        "allow"
    )
    assert decide_vote(far, (1.0, "r"), book, circle, claims=frozenset({("c1-c2", 1)})) == ("lock")
    book.add_request(
        RequestEntry(2, 5.0, Area(shapely.box(50, 0, 52, 1)), (0.5, "v"), frozenset({("c2-c3", 0)}))
    )
    assert decide_vote(far, (1.0, "r"), book, circle, claims=frozenset({("c2-c3", 1)})) == (
        "priority"
    )


def test_agvs_follow_through_the_corridor_and_never_hold_it_both_ways() -> None:
    # A seed whose run has AGVs follow each other (seeds 1 to 8 happen to have none since
    # a drop station takes one load at a time).
    cfg = FleetConfig(
        agvs=4, seed=9, task_interval=15.0, start_tasks=4, task_until=300.0, fail_on_violation=True
    )
    fleet = Fleet(corridor_loops(), cfg)
    followed = 0
    while fleet.now < 400.0:
        fleet.step()
        held = [agv.book.claims() for agv in fleet.agvs.values()]
        for a, b in itertools.combinations(held, 2):
            assert not claims_conflict(a, b), (a, b)
        in_corridor = [
            agv
            for agv in fleet.agvs.values()
            if abs(agv.vehicle.pose().y) < 0.5 and 3.0 < agv.vehicle.pose().x < 37.0
        ]
        followed += len(in_corridor) >= 2
    figures = fleet.summary()
    assert figures["collisions"] == figures["lock_overlaps"] == figures["deadlocks"] == 0
    assert followed > 0  # two AGVs in the corridor at once: only by following
    assert figures["tasks_completed"] >= 6


def test_a_follower_leaving_a_dead_end_spur_never_waits_across_the_lane_it_joins() -> None:
    # From the station A3-3e (a 2.5 m two-way spur east of aisle A3) the route runs up
    # the aisle to the N lane. The spur, the aisle and its keep-clear box make one zone
    # the route drives through; a follower may wait in it, but only beyond the spur
    # and its clearance: just past the zone's start the hull lies across the aisle.
    fleet = Fleet(
        demo_warehouse(),
        FleetConfig(agvs=1, seed=1, task_interval=1e9, start_tasks=0),
        homes=["N5300n"],
        starts=["A3-3e"],
    )
    agv = fleet.agvs["agv-01"]
    route = agv._route_for("N5300n")
    plan = agv.routing.plan_for(route)
    assert route.points[:2] == ("A3-3e", "A3-3")
    spur_clear = route.offsets[1] + plan.clearance
    assert plan.through[0]
    assert plan.zones[0][0] < 0.0 < spur_clear < plan.zones[0][1]
    assert plan.hard[0] == (plan.zones[0][0], spur_clear)
    for advance in (1.25, 2.0, 3.0, 4.0):
        stop = plan.next_stop(0.0, advance, follow=True)
        assert stop >= spur_clear - 1e-9, (advance, stop)
        assert not any(lo < stop < hi for lo, hi in plan.hard)
    assert plan.next_stop(0.0, 5.0, follow=True) == 5.0  # beyond it, as before
