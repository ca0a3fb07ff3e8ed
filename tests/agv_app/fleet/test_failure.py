"""A crashed AGV stays on the floor: the others keep out of its last known circle."""

from __future__ import annotations

import math

from agv_app.fleet import Fleet, FleetConfig
from agv_app.geometry import overlaps
from agv_app.layout import Layout, Point, Segment
from agv_app.traffic import stale_area


def lane() -> Layout:
    pts = [Point(f"p{x}", float(x), 0.0) for x in (0, 10, 50, 60)]
    segs = [Segment("a", "p0", "p10"), Segment("b", "p10", "p50"), Segment("c", "p50", "p60")]
    return Layout(pts, segs)


def test_others_never_drive_into_a_failed_agv_and_the_record_goes_when_it_returns() -> None:
    cfg = FleetConfig(agvs=2, seed=9, fail_on_violation=True)
    fleet = Fleet(lane(), cfg, homes=["p60", "p50"], starts=["p10", "p0"], headings=[0.0, 0.0])
    a, b = fleet.agvs["agv-01"], fleet.agvs["agv-02"]
    fleet.run(8.0)
    assert 0.5 < a.vehicle.s < 30
    fleet.crash("agv-01")
    crashed_at = a.vehicle.pose()
    fleet.run(5.0)  # the failure is detected within 3 * t_update
    records = b.book.stale()
    assert [r.node_id for r in records] == ["agv-01"]
    circle = stale_area(records[0])
    assert circle.contains(a.vehicle.hull())
    reach = b.book.lock_end()
    held = [e.area for e in b.book.locks()]
    fleet.run(55.0)
    assert a.vehicle.pose() == crashed_at  # stopped where it stood
    # b locks nothing new inside the circle: it drives only over what it held before.
    assert b.book.lock_end() == reach
    for lock in b.book.locks():
        assert not overlaps(lock.area.difference(held[0].union(held[-1])), circle)
    assert b.vehicle.speed == 0.0
    assert b.point != b.home
    fleet.recover("agv-01")
    fleet.run(3.0)
    assert b.book.stale() == []
    fleet.run(90.0)
    assert a.point == a.home
    assert b.point == b.home
    assert fleet.monitor.collisions == fleet.monitor.lock_overlaps == 0
    assert math.isclose(fleet.net.now, 161.0)
