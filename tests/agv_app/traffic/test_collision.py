"""Collision avoidance scenarios on tiny layouts, in virtual time, with the monitor on."""

from __future__ import annotations

import math

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.geometry import Area, Polyline, hull_projection
from agv_app.layout import Layout, Point, Segment
from agv_app.traffic import (
    LockBook,
    LockEntry,
    RequestEntry,
    Requester,
    Voter,
    collision_group,
    decide_vote,
)
from objectplaces.sim import SimulatedNetwork


def crossing() -> Layout:
    """Two one-way lanes crossing at X (0, 0): west->east and south->north."""
    pts = [Point("W", -20, 0), Point("X", 0, 0), Point("E", 20, 0)]
    pts += [Point("S", 0, -20), Point("N", 0, 20)]
    segs = [Segment("WX", "W", "X"), Segment("XE", "X", "E")]
    segs += [Segment("SX", "S", "X"), Segment("XN", "X", "N")]
    return Layout(pts, segs, name="crossing")


def run_until_home(fleet: Fleet, limit: float) -> None:
    def home() -> bool:
        return all(a.point == a.home and a.phase == "home" for a in fleet.agvs.values())

    while fleet.net.now < limit and not home():
        fleet.step()
    assert home(), {a.node_id: (a.phase, a.vehicle.s) for a in fleet.agvs.values()}


def config(**kw: float) -> FleetConfig:
    base: dict[str, object] = {"agvs": 2, "seed": 3, "fail_on_violation": True}
    base.update(kw)
    return FleetConfig(**base)  # type: ignore[arg-type]


def test_crossing_at_an_intersection() -> None:
    fleet = Fleet(crossing(), config(), homes=["E", "N"], starts=["W", "S"], headings=[0, 1.5708])
    run_until_home(fleet, 120.0)
    assert fleet.monitor.collisions == fleet.monitor.lock_overlaps == 0
    assert len(fleet.metrics_raw.lock_waits) >= 4


@pytest.mark.parametrize(
    ("delay", "loss", "reorder"),
    [(0.005, 0.0, 0.0), (0.05, 0.0, 0.0), (0.02, 0.1, 0.0), (0.02, 0.05, 0.2)],
)
def test_crossing_under_delay_loss_and_reordering(
    delay: float, loss: float, reorder: float
) -> None:
    cfg = config(delay=delay, jitter=delay / 2, loss=loss, reorder=reorder)
    fleet = Fleet(crossing(), cfg, homes=["E", "N"], starts=["W", "S"], headings=[0, 1.5708])
    run_until_home(fleet, 300.0)


def head_on_lane() -> Layout:
    """A two-way lane between junctions A and B, with one-way loops at both ends."""
    pts = [Point("A", 0, 0), Point("B", 20, 0)]
    pts += [Point("A1", -10, 5), Point("A2", -10, -5), Point("B1", 30, 5), Point("B2", 30, -5)]
    segs = [Segment("AB", "A", "B", bidirectional=True)]
    segs += [Segment("A1A", "A1", "A"), Segment("AA2", "A", "A2")]
    segs += [Segment("B1B", "B1", "B"), Segment("BB2", "B", "B2")]
    return Layout(pts, segs, name="head-on")


@pytest.mark.parametrize("loss", [0.0, 0.1])
def test_head_on_on_a_bidirectional_lane_never_deadlocks(loss: float) -> None:
    cfg = config(loss=loss, reorder=0.1 if loss else 0.0)
    fleet = Fleet(head_on_lane(), cfg, homes=["B2", "A2"], starts=["A1", "B1"])
    run_until_home(fleet, 300.0)
    assert fleet.stalls.deadlocks == 0


def test_the_passage_through_a_two_way_lane_is_one_request() -> None:
    fleet = Fleet(head_on_lane(), config(agvs=1), homes=["B2"], starts=["A1"])
    agv = fleet.agvs["agv-01"]
    fleet.step()
    fleet.step()
    plan = agv._plan
    assert plan is not None
    # No resting place from before the mouth at A to beyond the far end B.
    assert not any(plan.may_rest(s) for s in (11.0, 15.0, 25.0, 33.0))
    assert plan.may_rest(5.0)


# -- the rule and the roles, one message at a time ------------------------------------------


def strip(x0: float, x1: float) -> Area:
    return hull_projection(Polyline([(x0, 0.0), (x1, 0.0)]), 0, x1 - x0, length=2, width=1)


def test_decide_vote_rule() -> None:
    net = SimulatedNetwork(seed=1)
    book = LockBook(net.add_node("v").space)
    book.set_locks(LockEntry(1, 0.0, strip(0, 2)))
    book.add_request(RequestEntry(2, 0.0, strip(2, 6), (5.0, "v")))

    def around(area: Area) -> tuple[float, float, float]:
        # The requester's circle as published: centred on the area, covering it.
        x0, y0, x1, y1 = area.geom.bounds
        return (x0 + x1) / 2, (y0 + y1) / 2, math.hypot(x1 - x0, y1 - y0)

    for area, priority, verdict in (
        (strip(10, 12), 1.0, "allow"),
        (strip(-1, 1), 1.0, "lock"),
        (strip(4, 8), 1.0, "allow"),  # higher priority
        (strip(4, 8), 9.0, "priority"),
    ):
        assert decide_vote(area, (priority, "r"), book, around(area)) == verdict
    assert decide_vote(strip(10, 12), (1.0, "r"), book) == "group"  # not in view


def test_a_voter_waits_for_a_circle_that_covers_the_request() -> None:
    # The paper's rule let a voter allow a requester merely in its own circle group; with
    # a stale view of the requester's circle that group may hold it while the circle
    # misses the box of the voter's own request, which would then lock without it.
    net = SimulatedNetwork(seed=1)
    book = LockBook(net.add_node("v").space)
    covering, stale = (11.0, 0.0, 3.0), (11.0, 0.0, 0.5)
    assert decide_vote(strip(10, 12), (1.0, "r"), book, covering) == "allow"
    assert decide_vote(strip(10, 12), (1.0, "r"), book, stale) == "group"


class Node:
    """A bare AGV node: properties, a voter factory, locks written by hand."""

    def __init__(self, net: SimulatedNetwork, name: str, x: float, r: float) -> None:
        self.node = net.add_node(name)
        self.book = LockBook(self.node.space)
        self.voters: list[Voter] = []
        self.node.update_node_property("kind", "agv")
        self.move(x, r)

        def factory() -> Voter:
            voter = Voter(view=self.node.view, recheck=0.25)
            self.voters.append(voter)
            return voter

        self.node.set_participant_factory("voter", factory)

    def move(self, x: float, r: float) -> None:
        self.node.update_node_property("position", (x, 0.0))
        self.node.update_node_property("hull_length", r)

    def request(
        self,
        x0: float,
        x1: float,
        t: float,
        *,
        announced_at: float | None = None,
        outcomes: list[str] | None = None,
    ) -> Requester:
        """Ask for the strip x0..x1, ranked at ``t``; each outcome goes to ``outcomes``."""
        entry = RequestEntry(1, x1, strip(x0, x1), (t, self.node.node_id))
        self.book.add_request(entry)
        req = Requester(
            entry,
            safe_time=2.0,
            group_view=lambda: self.node.view_group(collision_group()),
            on_done=(outcomes if outcomes is not None else []).append,
            announced_at=announced_at,
        )
        self.node.start_interaction(req, collision_group(), "voter")
        return req


def test_a_newcomer_gets_the_request_and_the_lock_waits_for_its_vote() -> None:
    net = SimulatedNetwork(seed=2, property_interval=1.0)
    a = Node(net, "a", 0.0, 6.0)
    b = Node(net, "b", 40.0, 1.2)
    b.book.set_locks(LockEntry(1, 0.0, strip(39, 41)))
    net.run_for(0.5)
    req = a.request(0.0, 5.0, net.now)
    net.run_for(1.0)
    assert req.votes == {}
    # b drives into a's collision range while the request is pending and locks 4..6.
    b.book.set_locks(LockEntry(2, 0.0, strip(4, 6)))
    b.move(5.0, 1.2)
    net.run_for(0.5)
    assert req.votes == {"b": False}  # it got the request and deferred
    assert b.voters
    assert b.voters[0].verdict == "lock"
    net.run_for(3.0)
    assert req.done == ""  # patient: the lock may be released as b drives on
    net.run_for(1.5)
    assert req.done == "withdrawn"
    assert a.book.request() is None
    assert a.book.locks() == []


def test_a_voter_that_leaves_range_no_longer_counts() -> None:
    net = SimulatedNetwork(seed=2, property_interval=1.0)
    a = Node(net, "a", 0.0, 6.0)
    b = Node(net, "b", 8.0, 3.0)
    b.book.add_request(RequestEntry(7, 0.0, strip(4, 7), (0.0, "b")))  # b has priority
    net.run_for(0.5)
    req = a.request(0.0, 5.0, net.now)
    net.run_for(1.0)
    assert req.votes == {"b": False}
    assert b.voters[0].verdict == "priority"
    b.book.withdraw(7)
    b.move(30.0, 1.2)  # out of range: its vote is no longer needed
    net.run_for(2.0)
    assert req.done == "locked"
    assert [e.key for e in a.book.locks()] == [1]


def test_priority_decides_requested_vs_requested() -> None:
    net = SimulatedNetwork(seed=4, property_interval=1.0)
    a = Node(net, "a", 0.0, 7.0)
    b = Node(net, "b", 10.0, 7.0)
    net.run_for(0.5)
    ra = a.request(0.0, 6.0, 0.5)  # earlier: higher priority
    rb = b.request(10.0 - 6.0, 10.0, 0.6)
    net.run_until(lambda: ra.done != "", 10.0)
    assert ra.done == "locked"
    assert rb.done == ""
    assert a.voters[0].verdict == "priority" or a.voters[0].verdict == "lock"
    net.run_for(4.5)
    assert rb.done == "withdrawn"  # blocked by a's lock for too long: it backs off
    assert a.book.locks()[0].area.overlaps(strip(4, 10))
