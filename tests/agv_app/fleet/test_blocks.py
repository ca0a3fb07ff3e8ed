"""Closing parts of the floor in the simulated fleet: no vehicle enters a closed path,
one parked inside a closed area leaves it and waits, an order that needs a closed part
waits saying why and goes on when it reopens. Virtual time, seeded."""

from __future__ import annotations

import pytest
import shapely

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.blocks import CutsOff, UnknownBlock
from agv_app.layout.demo import demo_warehouse

SEGMENT = "M4550>M3925"  # a lane many routes use; closed, every station stays reachable


def _fleet(**kw: object) -> Fleet:
    cfg = FleetConfig(agvs=6, seed=3, fail_on_violation=True, **kw)  # type: ignore[arg-type]
    return Fleet(demo_warehouse(), cfg)


def _inside(fleet: Fleet, segment: str) -> set[str]:
    """The vehicles whose centre stands on ``segment``, short of both its ends."""
    line = shapely.LineString(fleet.layout.segment_coords(segment))
    ends = shapely.MultiPoint([line.coords[0], line.coords[-1]])
    found = set()
    for agv_id, agv in fleet.agvs.items():
        pose = agv.vehicle.pose()
        at = shapely.Point(pose.x, pose.y)
        if line.distance(at) < 1e-6 and ends.distance(at) > 1e-3:
            found.add(agv_id)
    return found


def test_a_closed_segment_is_never_entered_and_the_fleet_drives_round_it() -> None:
    fleet = _fleet(task_interval=15.0, task_until=400.0)
    bound = None
    for _ in range(round(200.0 / fleet.config.dt)):
        fleet.step()
        bound = next(
            (
                a
                for a, agv in fleet.agvs.items()
                if agv.vehicle.speed > 0.5
                and fleet.vehicle_route(a)
                and SEGMENT in (agv._route.segments if agv._route else ())
                and a not in _inside(fleet, SEGMENT)
            ),
            None,
        )
        if bound is not None:
            break
    assert bound is not None, "some vehicle is bound over the segment"
    fleet.blocks.close("segment", SEGMENT)
    done = fleet.summary()["tasks_completed"]
    for _ in range(round(240.0 / fleet.config.dt)):
        fleet.step()
        assert not _inside(fleet, SEGMENT), f"entered {SEGMENT} at t={fleet.now:.1f}"
    figures = fleet.summary()
    assert figures["tasks_completed"] > done, "the fleet works on round the closed path"
    assert figures["collisions"] == 0
    assert figures["deadlocks"] == 0


def test_a_vehicle_parked_in_a_closed_area_leaves_it_waits_and_comes_back() -> None:
    fleet = _fleet(task_until=0.0)
    agv = fleet.agvs["agv-01"]
    home = agv.home
    p = fleet.layout.point(home)
    square = [(p.x - 0.5, p.y - 0.5), (p.x + 0.5, p.y - 0.5), (p.x + 0.5, p.y + 0.5)]
    with pytest.raises(CutsOff, match="park-"):
        fleet.blocks.close("polygon", square)
    assert fleet.blocks.blocks() == [], "nothing half-applied"
    block = fleet.blocks.close("polygon", square, force=True)
    assert home in block.closed.points
    (spur,) = [s for s in fleet.layout.segments if home in (s.split(">"))]
    out = next(e for e in spur.split(">") if e != home)
    fleet.run(30.0)
    assert agv.point == out, "it drove out to the nearest open point"
    assert agv.vehicle.speed == 0.0
    assert agv.display_status() == "waiting"
    assert agv.blocked_to == home

    fleet.blocks.reopen(block.id)
    fleet.run(30.0)
    assert (agv.point, agv.phase) == (home, "home")
    assert not agv.blocked_to
    with pytest.raises(UnknownBlock, match=r"unknown block 'b1' \(known: none\)"):
        fleet.blocks.reopen(block.id)


def test_an_order_that_needs_a_closed_path_waits_saying_why_and_goes_on_when_reopened() -> None:
    fleet = _fleet(task_until=0.0)
    with pytest.raises(CutsOff, match="pick-A1-1"):
        fleet.blocks.close("segment", "A1-1>A1-1e")
    block = fleet.blocks.close("segment", "A1-1>A1-1e", force=True)
    task = fleet.create_task("pick-A1-1", "dock-out-1")
    fleet.run(60.0)
    record = fleet.desk.book.get(task)
    assert record is not None
    assert str(record.state) == "created", "no vehicle takes it"
    assert fleet.blocks.waits("pick-A1-1", "dock-out-1") == "waits: path A1-1>A1-1e closed"

    fleet.blocks.reopen(block.id)
    assert fleet.blocks.waits("pick-A1-1", "dock-out-1") is None
    for _ in range(round(300.0 / fleet.config.dt)):
        fleet.step()
        if str(record.state) == "done":
            break
    assert str(record.state) == "done"


def test_a_vehicle_waiting_for_its_closed_home_still_takes_orders() -> None:
    fleet = Fleet(demo_warehouse(), FleetConfig(agvs=1, seed=3, task_until=0.0))
    agv = fleet.agvs["agv-01"]
    p = fleet.layout.point(agv.home)
    square = [(p.x - 0.5, p.y - 0.5), (p.x + 0.5, p.y - 0.5), (p.x + 0.5, p.y + 0.5)]
    fleet.blocks.close("polygon", square, force=True)
    fleet.run(30.0)
    assert agv.blocked_to == agv.home
    waiting_at = agv.point
    task = fleet.create_task("pick-A1-1", "dock-out-1")
    record = fleet.desk.book.get(task)
    assert record is not None
    for _ in range(round(600.0 / fleet.config.dt)):
        fleet.step()
        if str(record.state) == "done":
            break
    assert str(record.state) == "done"
    fleet.run(120.0)
    assert agv.blocked_to == agv.home, "done, it waits for its home again"
    assert agv.point != agv.home
    assert waiting_at != agv.home


def test_a_vehicle_on_a_path_as_it_closes_drives_on_off_it_and_never_comes_back() -> None:
    fleet = _fleet(task_interval=15.0, task_until=400.0)
    on: set[str] = set()
    for _ in range(round(200.0 / fleet.config.dt)):
        fleet.step()
        on = _inside(fleet, SEGMENT)
        if any(fleet.agvs[a].vehicle.speed > 0.5 for a in on):
            break
    assert on, "some vehicle drives on the segment"
    fleet.blocks.close("segment", SEGMENT)
    end = fleet.layout.point(fleet.layout.segment(SEGMENT).end).xy
    left: dict[str, tuple[float, float]] = {}
    for _ in range(round(120.0 / fleet.config.dt)):
        before = {a: fleet.agvs[a].vehicle.pose() for a in on if a not in left}
        fleet.step()
        inside = _inside(fleet, SEGMENT)
        assert inside <= on - left.keys(), f"entered {SEGMENT} at t={fleet.now:.1f}"
        for a, pose in before.items():
            if a not in inside:
                left[a] = (pose.x, pose.y)
    assert left.keys() == on, "each drove off it"
    for a, (x, y) in left.items():
        assert abs(x - end[0]) + abs(y - end[1]) < 1.0, f"{a} left by the segment's end"
