"""Realistic load by default: the task rate follows from the load and the layout, the
fleet starts at its load, and the free-flow bound and long waits are reported."""

from __future__ import annotations

import itertools
import random
import statistics

import pytest

from agv_app.fleet import Fleet, FleetConfig, demo_source
from agv_app.fleet.mesh import MeshFleet
from agv_app.layout import Layout, Point, Segment
from agv_app.layout.demo import demo_warehouse
from agv_app.layout.shapes import crossing
from agv_app.tasks import (
    FreeFlowTimer,
    TaskArrivals,
    drop_stations,
    mean_task_seconds,
    pick_stations,
)


def demo_mean_task_seconds() -> float:
    layout = demo_warehouse()
    timer = FreeFlowTimer(layout, speed_m_s=1.5, dwell_s=5.0)
    return mean_task_seconds(timer, pick_stations(layout), drop_stations(layout))


@pytest.mark.parametrize("load", [0.7, 0.9])
def test_the_fleet_creates_tasks_at_the_rate_of_its_load(load: float) -> None:
    fleet = Fleet(demo_warehouse(), FleetConfig(agvs=6, seed=5, load=load))
    assert fleet.task_interval == pytest.approx(demo_mean_task_seconds() / (load * 6))
    assert len(fleet.open_tasks) == round(load * 6), "about load * N tasks at the start"


def test_a_seeded_stream_of_arrivals_keeps_its_mean_interval() -> None:
    arrivals = TaskArrivals(12.5, random.Random(1))
    times = [0.0]
    for _ in range(5000):
        times.append(arrivals.next_after(times[-1]))
    gaps = [b - a for a, b in itertools.pairwise(times)]
    assert statistics.fmean(gaps) == pytest.approx(12.5, rel=0.04)


def test_a_seeded_run_creates_about_the_target_number_of_tasks() -> None:
    fleet = Fleet(demo_warehouse(), FleetConfig(agvs=6, seed=5, load=0.9))
    assert fleet.task_interval is not None
    fleet.run(120.0)
    expected = round(0.9 * 6) + 120.0 / fleet.task_interval
    assert fleet.summary()["tasks_created"] == pytest.approx(expected, rel=0.35)


def test_a_task_interval_overrides_the_load_and_starts_without_tasks() -> None:
    fleet = Fleet(demo_warehouse(), FleetConfig(agvs=4, seed=1, task_interval=1e9))
    assert fleet.task_interval == 1e9
    assert fleet.open_tasks == []


@pytest.mark.parametrize("load", [0.0, 1.5, -1.0])
def test_a_fleet_refuses_a_load_outside_zero_to_one(load: float) -> None:
    with pytest.raises(ValueError, match=f"got {load!r}"):
        FleetConfig(load=load)


def test_the_demo_has_most_agvs_moving_within_ten_seconds() -> None:
    fleet = demo_source(agvs=12, seed=1, load=0.7)
    assert len(fleet.open_tasks) == 8
    fleet.advance(10.0)
    busy = [v.id for v in fleet.vehicles() if v.status != "idle"]
    assert len(busy) >= 7, [v.status for v in fleet.vehicles()]


def test_the_demo_takes_its_load_from_the_arguments_and_checks_it() -> None:
    import argparse

    fleet = demo_source(argparse.Namespace(agvs=10, seed=1, processes=0, load=0.5))
    assert isinstance(fleet, Fleet)
    assert len(fleet.open_tasks) == 5
    with pytest.raises(ValueError, match="got 2"):
        demo_source(agvs=2, load=2)


def lane() -> Layout:
    pts = [Point(f"p{x}", float(x), 0.0) for x in (0, 10, 50, 60)]
    segs = [Segment("a", "p0", "p10"), Segment("b", "p10", "p50"), Segment("c", "p50", "p60")]
    return Layout(pts, segs)


def test_a_forced_wait_shows_in_max_wait_and_stalls_60s() -> None:
    # agv-01 crashes ahead of agv-02 on a one-way lane: agv-02 waits behind it.
    cfg = FleetConfig(agvs=2, seed=9, fail_on_violation=True)
    fleet = Fleet(lane(), cfg, homes=["p60", "p50"], starts=["p10", "p0"], headings=[0.0, 0.0])
    fleet.run(8.0)
    fleet.crash("agv-01")
    fleet.run(30.0)
    forced = fleet.stalls.stalled_for("agv-02", fleet.now)
    assert 10.0 < forced < 60.0
    figures = fleet.summary()
    assert figures["max_wait"] >= round(forced, 2)
    assert figures["stalls_60s"] == 0
    fleet.run(40.0)
    figures = fleet.summary()
    assert figures["max_wait"] >= round(forced + 40.0, 2) > 60.0
    assert figures["stalls_60s"] == 1, "one wait over 60 s, counted once"
    assert figures["deadlocks"] == 0, "the 180 s safety exit is not reached"


def test_free_flow_bound_of_one_task_is_reached_no_later_than_its_delivery() -> None:
    fleet = Fleet(demo_warehouse(), FleetConfig(agvs=3, seed=4, task_interval=1e9))
    task_id = fleet.create_task("dock-in-1", "dock-out-1")
    assert fleet.summary()["free_flow_tasks_per_hour"] == 0.0
    record = fleet.desk.book.get(task_id)
    assert record is not None
    for _ in range(6000):
        fleet.step()
        if record.state == "done":
            break
    assert record.state == "done"
    figures = fleet.summary()
    assert figures["free_flow_tasks_per_hour"] == round(3600.0 / fleet.now, 2)
    assert figures["free_flow_tasks_per_hour"] >= figures["tasks_per_hour"] > 0


def test_on_a_crossing_of_two_way_lanes_the_load_is_a_share_of_what_the_crossing_carries() -> None:
    # Eight AGVs on one crossing: the floor keeps about one busy, so load 0.7 starts one
    # task, not six, and tasks come at 0.7 of what the crossing lets through.
    layout = crossing()
    fleet = Fleet(layout, FleetConfig(agvs=8, seed=1, load=0.7))
    spec = fleet.spec
    timer = FreeFlowTimer(layout, spec.max_speed_m_s, fleet.config.dwell)
    mean = mean_task_seconds(timer, pick_stations(layout), drop_stations(layout))
    assert fleet.task_interval is not None
    assert fleet.task_interval > 4 * mean / (0.7 * 8)
    assert fleet.desk.book.open_count == 1
    # Asked for the fleet's own share instead, the crossing gets six at once and more.
    past = Fleet(layout, FleetConfig(agvs=8, seed=1, load=0.7, load_of="fleet"))
    assert past.task_interval == pytest.approx(mean / (0.7 * 8))
    assert past.desk.book.open_count == 6
    with pytest.raises(ValueError, match="load_of must be one of"):
        FleetConfig(load_of="floor")


def test_a_demo_of_more_agv_processes_than_the_floor_keeps_busy_starts_and_runs_at_its_load() -> (
    None
):
    # The demo warehouse keeps about 16 AGVs busy: 50 processes at load 0.7 start 11
    # tasks and get one every 9.6 s, as 20 would; 10 processes start 7.
    many = demo_source(processes=50, seed=1)
    few = demo_source(processes=10, seed=1)
    assert isinstance(many, MeshFleet)
    assert isinstance(few, MeshFleet)
    assert many.auto_tasks.start_tasks == 11
    # (the simulated fleet's passes also count its step, 0.1 s each)
    simulated = Fleet(None, FleetConfig(agvs=20)).task_interval
    assert many.task_interval == pytest.approx(simulated, rel=0.01)
    assert few.auto_tasks.start_tasks == 7
