"""The task rate that keeps a target share of the fleet busy, and the free-flow times."""

from __future__ import annotations

import math

import pytest

from agv_app.layout import Layout, Point, Segment, Station
from agv_app.layout.demo import demo_warehouse
from agv_app.layout.generated import generated_warehouse
from agv_app.tasks import (
    FloorRules,
    FreeFlowBound,
    FreeFlowTimer,
    TaskSpec,
    carried_tasks,
    check_load,
    drop_stations,
    floor_capacity,
    initial_tasks,
    mean_task_seconds,
    pick_stations,
    shared_part_seconds,
    task_interval_for_load,
)
from agv_app.tasks.load import standstill_pass
from agv_app.vehicle.kinematics import VehicleSpec


def lane() -> Layout:
    """A 30 m two-way lane: pick at p0, drop at p30, parking at p45."""
    pts = [Point("p0", 0.0, 0.0), Point("p30", 30.0, 0.0), Point("p45", 45.0, 0.0)]
    segs = [Segment("a", "p0", "p30", True), Segment("b", "p30", "p45", True)]
    stations = [
        Station("in", "p0", "pick"),
        Station("out", "p30", "drop"),
        Station("park", "p45", "parking"),
    ]
    return Layout(pts, segs, stations)


TIMER = FreeFlowTimer(lane(), speed_m_s=1.5, dwell_s=5.0)
TASK = TaskSpec("task-1", "in", "out")


@pytest.mark.parametrize("load", [0.0, -0.1, 1.01, math.nan, math.inf, "0.7", True, None])
def test_a_load_outside_zero_to_one_is_refused_showing_the_value(load: object) -> None:
    with pytest.raises(ValueError, match=r"\(0, 1\].*" + repr(load).replace("(", r"\(")):
        check_load(load)  # type: ignore[arg-type]


def test_loads_in_zero_to_one_pass() -> None:
    assert check_load(1) == 1.0
    assert check_load(0.7) == 0.7
    assert initial_tasks(agvs=20, load=0.7) == 14
    assert initial_tasks(agvs=3, load=0.5) == 2


def test_the_mean_task_time_is_approach_carry_and_two_dwells() -> None:
    # From the drop back to the pick (20 s), to the drop (20 s), 5 s at each end.
    assert mean_task_seconds(TIMER, ["in"], ["out"]) == pytest.approx(50.0)
    assert TIMER.task_seconds("p45", TASK) == pytest.approx(30 + 20 + 10)


def test_the_task_interval_keeps_the_load_busy() -> None:
    # 1 AGV at half load: busy half the time at 50 s a task, one task every 100 s.
    interval = task_interval_for_load(lane(), agvs=1, load=0.5, speed_m_s=1.5, dwell_s=5.0)
    assert interval == pytest.approx(100.0)
    with pytest.raises(ValueError, match="got 0"):
        task_interval_for_load(lane(), agvs=0, load=0.5, speed_m_s=1.5, dwell_s=5.0)


def test_on_one_two_way_lane_the_load_is_a_share_of_what_the_lane_carries() -> None:
    # The lane carries one AGV at a time: the pick's end is held 20 s on the carry, 20 s
    # on the way back and 5 s at the dwell, 45 s a task, whatever the fleet. Half of
    # that is a task every 90 s for 4 AGVs as for 100, not one every 25 s.
    capacity = floor_capacity(TIMER, ["in"], ["out"])
    assert capacity.bottleneck == "point:p0"
    assert capacity.busy_s == pytest.approx(45.0)
    for agvs in (4, 100):
        interval = task_interval_for_load(lane(), agvs=agvs, load=0.5, speed_m_s=1.5, dwell_s=5.0)
        assert interval == pytest.approx(90.0)


def test_a_floor_of_one_way_lanes_with_room_keeps_the_fleets_rate() -> None:
    # The demo warehouse carries over a hundred AGVs: 20 at load 0.7 are 14 busy.
    layout = demo_warehouse()
    timer = FreeFlowTimer(layout, 1.5, 5.0)
    mean = mean_task_seconds(timer, pick_stations(layout), drop_stations(layout))
    carried = floor_capacity(timer, pick_stations(layout), drop_stations(layout))
    assert carried.tasks_per_second > 100 / mean
    interval = task_interval_for_load(layout, agvs=20, load=0.7, speed_m_s=1.5, dwell_s=5.0)
    assert interval == pytest.approx(mean / 14)


def test_a_station_serves_one_agv_at_a_time_and_a_floor_without_shared_parts_has_no_bound() -> None:
    one_way = Layout(
        [Point("a", 0.0, 0.0), Point("b", 30.0, 0.0)],
        [Segment("ab", "a", "b"), Segment("ba", "b", "a", via=((15.0, 10.0),))],
        [Station("in", "a", "pick"), Station("out", "b", "drop")],
    )
    dwelling = floor_capacity(FreeFlowTimer(one_way, 1.5, 5.0), ["in"], ["out"])
    assert (dwelling.bottleneck, dwelling.busy_s) == ("point:a", 5.0)
    free = floor_capacity(FreeFlowTimer(one_way, 1.5, 0.0), ["in"], ["out"])
    assert free.bottleneck is None
    assert free.tasks_per_second == math.inf
    assert str(free) == "no shared part"


def test_a_layout_without_tasks_to_make_is_refused() -> None:
    bare = Layout([Point("p0", 0.0, 0.0), Point("p1", 9.0, 0.0)], [Segment("a", "p0", "p1")])
    with pytest.raises(ValueError, match="no pick and drop stations"):
        task_interval_for_load(bare, agvs=2, load=0.5, speed_m_s=1.5, dwell_s=5.0)


def test_the_bound_replays_tasks_back_to_back_from_where_each_vehicle_stands() -> None:
    bound = FreeFlowBound(TIMER, ["p0"])
    bound.add(TASK, 0.0)  # from p0: 0 + 20 + 10 = 30 s
    bound.add(TaskSpec("task-2", "in", "out"), 1.0)  # waits for the vehicle; from p30: 50 s
    assert bound.completed(29.9) == 0
    assert bound.completed(30.0) == 1
    assert bound.completed(79.9) == 1
    assert bound.completed(80.0) == 2
    assert bound.per_hour(3600.0) == pytest.approx(2.0)


def test_the_bound_shares_tasks_among_its_vehicles_and_idles_between_arrivals() -> None:
    bound = FreeFlowBound(TIMER, ["p0", "p45"])
    bound.add(TASK, 0.0)  # vehicle 0 from p0: done at 30
    bound.add(TaskSpec("task-2", "in", "out"), 0.0)  # vehicle 1 from p45: 30 + 20 + 10 = 60
    bound.add(TaskSpec("task-3", "in", "out"), 100.0)  # vehicle 0 idle till then: 150
    assert [bound.completed(t) for t in (30.0, 60.0, 149.0, 150.0)] == [1, 2, 2, 3]


def test_a_bound_needs_vehicles() -> None:
    with pytest.raises(ValueError, match="at least one vehicle"):
        FreeFlowBound(TIMER, [])


def test_a_floor_carries_about_one_task_per_20_m_of_lane() -> None:
    assert carried_tasks(demo_warehouse()) == 22
    assert carried_tasks(generated_warehouse(100)) == 15
    # A corridor driven through (one-way in at one end, out at the other) is lane too.
    points = [Point(f"p{i}", 20.0 * i, 0.0) for i in range(4)]
    corridor = [Segment("in", "p0", "p1"), Segment("run", "p1", "p2", True)]
    corridor.append(Segment("out", "p2", "p3"))
    assert carried_tasks(Layout(points, corridor)) == 3


def test_a_floor_of_dead_end_lanes_has_no_lane_to_carry_tasks() -> None:
    assert carried_tasks(lane()) is None


def test_a_fleets_pass_holds_a_stretch_from_a_standstill_and_for_the_handover() -> None:
    spec = VehicleSpec(1.0, 0.8, max_speed_m_s=1.5, max_accel_m_s2=0.75)
    hold = standstill_pass(spec, t_update=1.0, step_s=0.1)
    # 30 m: 2 s up to speed and 2 s down cover 3 m, 27 m more at 1.5 m/s; then 1.6 s.
    assert hold(30.0) == pytest.approx(4.0 + 18.0 + 1.6)
    assert hold(30.0) > 30.0 / 1.5
    slower = floor_capacity(TIMER, ["in"], ["out"], FloorRules(hold)).busy_s
    assert slower > floor_capacity(TIMER, ["in"], ["out"]).busy_s


def test_a_station_that_calls_one_agv_at_a_time_is_busy_while_its_winner_comes() -> None:
    # One pick at p0, one drop at p30 on a 30 m lane: the pick waits out each
    # approach (20 s), the drop each carry (20 s) when loads bound for it count too.
    parts = shared_part_seconds(TIMER, ["in"], ["out"], FloorRules(one_at_a_time=True))
    assert parts["station:in"] == pytest.approx(20.0)
    assert "station:out" not in parts
    both = FloorRules(one_at_a_time=True, wait_for_drop=True)
    assert shared_part_seconds(TIMER, ["in"], ["out"], both)["station:out"] == pytest.approx(20.0)
    assert "station:in" not in shared_part_seconds(TIMER, ["in"], ["out"])
