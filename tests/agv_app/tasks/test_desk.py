"""The task desk over a real fleet: a task's whole life in the book, and cancelling."""

from __future__ import annotations

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout import Layout, Point, Segment, Station
from agv_app.layout.demo import demo_warehouse
from agv_app.layout.elements import StationKind
from agv_app.tasks import require_task_stations

PICK = "dock-in-1"


def quiet_fleet() -> Fleet:
    """Three AGVs and no automatic tasks."""
    return Fleet(demo_warehouse(), FleetConfig(agvs=3, seed=4, task_interval=1e9))


def test_the_book_follows_a_task_from_creation_to_delivery() -> None:
    fleet = quiet_fleet()
    task_id = fleet.create_task(PICK, "dock-out-1")
    record = fleet.desk.book.get(task_id)
    assert record is not None
    assert (record.state, record.task.pick, record.task.drop) == ("created", PICK, "dock-out-1")
    for _ in range(6000):
        fleet.step()
        if record.state == "done":
            break
    assert record.state == "done", record
    times = record.times
    assert times["created"] == 0.0
    assert times["created"] < times["assigned"] <= times["driving"] < times["done"]
    assert record.vehicle in fleet.agvs
    assert fleet.open_tasks == []
    figures = fleet.summary()
    assert figures["tasks_completed"] == 1
    assert figures["task_time_mean"] == round(times["done"], 2)


def test_a_task_is_cancelled_before_its_award_and_never_carried() -> None:
    fleet = quiet_fleet()
    station = fleet.stations[PICK]
    first = fleet.create_task(PICK)
    second = fleet.create_task(PICK)  # queued behind the first
    fleet.cancel_task(first)  # its auction is running: it stops
    fleet.cancel_task(second)
    assert list(station.queue) == []
    assert station.current is None
    fleet.run(30.0)
    assert all(agv.task is None and agv.pending_task is None for agv in fleet.agvs.values())
    book = fleet.desk.book
    assert book.counts["cancelled"] == 2
    assert book.counts["assigned"] == 0
    assert fleet.open_tasks == []


def test_a_held_or_unknown_task_cannot_be_cancelled() -> None:
    fleet = quiet_fleet()
    task_id = fleet.create_task(PICK)
    for _ in range(600):
        fleet.step()
        if task_id in fleet.desk.book.open_ids() and fleet.desk.book.counts["assigned"]:
            break
    with pytest.raises(ValueError, match=rf"task {task_id!r} is (assigned|driving) to 'agv-"):
        fleet.cancel_task(task_id)
    with pytest.raises(KeyError, match="task-99"):
        fleet.cancel_task("task-99")


def _lane(*stations: tuple[str, str, StationKind]) -> Layout:
    """A two-way lane a - b - c with the given stations (id, point, kind)."""
    points = [Point(p, float(x), 0.0) for p, x in (("a", 0), ("b", 10), ("c", 20))]
    segments = [
        Segment("a-b", "a", "b", bidirectional=True),
        Segment("b-c", "b", "c", bidirectional=True),
    ]
    return Layout(points, segments, [Station(*s) for s in stations], name="lane")


def test_tasks_need_a_pick_and_another_drop_station_that_reach_each_other() -> None:
    require_task_stations(_lane(("in", "a", "pick"), ("out", "c", "drop")))
    require_task_stations(_lane(("x", "a", "pickdrop"), ("y", "c", "pickdrop")))
    cases: tuple[list[tuple[str, str, StationKind]], ...] = (
        [("x", "a", "pickdrop"), ("park", "c", "parking")],
        [("in", "a", "pick"), ("in2", "c", "pick")],
    )
    for stations in cases:
        with pytest.raises(ValueError, match="layout 'lane' cannot host a fleet"):
            require_task_stations(_lane(*stations))
    reason = r"group of stations that reach each other is 'park' \(parking\), 'x' \(pickdrop\)$"
    with pytest.raises(ValueError, match=reason):
        Fleet(_lane(("x", "a", "pickdrop"), ("park", "c", "parking")), FleetConfig(agvs=1))
