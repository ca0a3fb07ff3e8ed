"""A restarted AGV process comes back where its vehicle stands (the simulated driver's
state file), announces its hull there before it locks anything, and hands back the
task it held."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.geometry import Pose
from agv_app.layout import Layout, Point, Segment
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
from agv_app.vehicle import AgvController, SimDriver, VehicleSpec
from agv_app.vehicle.comeback import LocationError, Placement, locate
from agv_app.vehicle.state_file import StateFile

SPEC = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)


def lane() -> Layout:
    pts = [Point(f"p{x}", float(x), 0.0) for x in (0, 10, 50, 60)]
    segs = [
        Segment("a", "p0", "p10"),
        Segment("b", "p10", "p50"),
        Segment("c", "p50", "p60", bidirectional=True),
    ]
    return Layout(pts, segs)


def kept_in(directory: Path) -> Callable[[str, Pose], SimDriver]:
    """Simulated drivers that keep their pose in ``directory``, one file per AGV."""

    def build(agv_id: str, pose: Pose) -> SimDriver:
        return SimDriver.recovered(SPEC, StateFile(directory / f"{agv_id}.json"), default=pose)

    return build


def test_a_pose_is_placed_on_the_point_or_the_segment_it_lies_on() -> None:
    layout = lane()
    assert locate(layout, Pose(10.004, 0.0, 0.0)) == Placement("p10")
    assert locate(layout, Pose(30.0, 0.05, 0.0)) == Placement("p50", "p10", 20.0)
    # A two-way segment is driven the way the vehicle faces.
    assert locate(layout, Pose(52.0, 0.0, 3.1)) == Placement("p50", "p60", 8.0)
    assert locate(layout, Pose(52.0, 0.0, 0.1)) == Placement("p60", "p50", 2.0)
    with pytest.raises(LocationError, match="on no point or segment"):
        locate(layout, Pose(30.0, 2.0, 0.0))


def test_a_restarted_agv_comes_back_where_it_stood_and_waits_before_it_locks(
    tmp_path: Path,
) -> None:
    cfg = FleetConfig(agvs=2, seed=9, fail_on_violation=True)
    fleet = Fleet(
        lane(),
        cfg,
        spec=SPEC,
        homes=["p60", "p50"],
        starts=["p10", "p0"],
        headings=[0.0, 0.0],
        drivers=kept_in(tmp_path),
    )
    fleet.run(10.0)
    old = fleet.agvs["agv-01"]
    assert 15.0 < old.vehicle.pose().x < 45.0  # on its way home, on segment b
    fleet.crash("agv-01")
    stood = old.vehicle.pose()
    fleet.run(5.0)
    assert [r.node_id for r in fleet.agvs["agv-02"].book.stale()] == ["agv-01"]

    agv = fleet.reboot("agv-01")
    back_at = fleet.now
    assert agv is not old
    assert agv.vehicle.pose() == stood  # where it stood, not at its home
    assert agv.node.properties["position"] == pytest.approx((stood.x, stood.y), abs=1e-3)
    assert (agv.point, agv.phase) == ("p10", "lost")  # it drives on to p50 first
    standing = agv.vehicle.s
    # Nothing asked for, nothing locked beyond its own hull, for the safe time.
    while fleet.now < back_at + 2 * cfg.t_update - 1e-9:
        assert agv.book.request() is None
        assert agv.book.lock_end() == standing
        fleet.step()
    # Then it asks, and the request waits the safe time of the circle that covers it.
    _until(fleet, lambda: agv.book.lock_end() > standing, 5.0)
    assert fleet.now >= back_at + 4 * cfg.t_update
    assert fleet.agvs["agv-02"].book.stale() == []  # heard again: no stale record
    fleet.run(60.0)
    assert agv.point == agv.home == "p60"
    assert fleet.monitor.collisions == fleet.monitor.lock_overlaps == 0


def _until(fleet: Fleet, done: Callable[[], bool], seconds: float) -> None:
    for _ in range(round(seconds / fleet.config.dt)):
        if done():
            return
        fleet.step()
    raise AssertionError(f"not within {seconds} s")


def _busy(fleet: Fleet, phase: str) -> AgvController:
    found: list[AgvController] = []

    def there() -> bool:
        found[:] = [a for a in fleet.agvs.values() if a.phase == phase and a.task is not None]
        return bool(found)

    _until(fleet, there, 300.0)
    return found[0]


def test_a_loaded_task_is_handed_back_and_resumed_at_the_drop_station(tmp_path: Path) -> None:
    fleet = Fleet(None, FleetConfig(agvs=6, seed=4, load=0.8), spec=SPEC, drivers=kept_in(tmp_path))
    carrier = _busy(fleet, "to_drop")
    task = carrier.task
    assert task is not None
    fleet.crash(carrier.node_id)
    agv = fleet.reboot(carrier.node_id)
    props = agv.node.properties
    assert (props["task"], props["returned"], props["reached_pick"]) == (None, task.id, task.id)
    assert agv.status == "idle"
    # The transport base decides it is still this AGV's: it awards it again.
    agv.take(task)
    fleet.step()
    assert (agv.task, agv.phase) == (task, "to_drop")
    assert agv.node.properties["returned"] is None
    _until(fleet, lambda: agv.last_done == task.id, 300.0)
    assert fleet.monitor.collisions == fleet.monitor.lock_overlaps == 0


def test_a_task_not_yet_picked_goes_back_to_its_station(tmp_path: Path) -> None:
    fleet = Fleet(None, FleetConfig(agvs=6, seed=4, load=0.8), spec=SPEC, drivers=kept_in(tmp_path))
    carrier = _busy(fleet, "to_pick")
    task = carrier.task
    assert task is not None
    fleet.crash(carrier.node_id)
    fleet.run(5.0)  # the base finds the node gone
    agv = fleet.reboot(carrier.node_id)
    props = agv.node.properties
    assert (props["task"], props["returned"], props["reached_pick"]) == (None, task.id, None)
    assert agv.handed_back is not None
    assert not agv.handed_back.loaded
    _until(fleet, lambda: fleet.desk.returned == 1, 30.0)  # put back in its queue
    assert fleet.monitor.collisions == fleet.monitor.lock_overlaps == 0
