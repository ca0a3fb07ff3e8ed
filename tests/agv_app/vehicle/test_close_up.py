"""A request held up by a lock while the AGV stands asks again for half the stretch."""

from __future__ import annotations

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout import Layout, Point, Segment


def lane() -> Layout:
    """One straight one-way lane, A to B to C, 20 m apart."""
    points = [Point("A", 0.0, 0.0), Point("B", 20.0, 0.0), Point("C", 40.0, 0.0)]
    return Layout(points, [Segment("A-B", "A", "B"), Segment("B-C", "B", "C")], name="lane")


def gap_behind_a_standing_agv() -> float:
    """Drive agv-02 from A towards C while agv-01 stands at B: the gap where it stops."""
    cfg = FleetConfig(agvs=2, seed=1, task_interval=1e9, start_tasks=0, fail_on_violation=True)
    fleet = Fleet(lane(), cfg, homes=["B", "C"], starts=["B", "A"])
    fleet.run(60.0)
    leader, follower = fleet.agvs["agv-01"], fleet.agvs["agv-02"]
    assert leader.point == "B"
    assert follower.vehicle.speed == 0.0
    return leader.vehicle.pose().x - follower.vehicle.pose().x


def test_an_agv_held_up_by_a_standing_one_closes_up_behind_it() -> None:
    # Whole 5 m requests leave the follower up to 5 m short of the leader's hull; the
    # halved ones bring it within 1.25 m of it (2 m hulls: centres 3.25 m apart).
    assert gap_behind_a_standing_agv() <= 2.0 + 1.25 + 0.1
