"""The desk holds at most ``backlog`` open tasks: more are refused, and counted."""

from __future__ import annotations

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.tasks.desk import BACKLOG_LIMIT, BacklogFull, TaskDesk
from tests.agv_app.tasks.desks import demo_desk

PICK = "dock-in-1"


def _desk(backlog: int) -> TaskDesk:
    return demo_desk(backlog=backlog)[0]


def test_a_full_desk_refuses_a_task_until_one_is_done_or_cancelled() -> None:
    desk = _desk(backlog=3)
    ids = [desk.create(PICK, "dock-out-1") for _ in range(3)]
    with pytest.raises(BacklogFull, match="3 tasks are open, as many as the task desk holds"):
        desk.create(PICK)
    assert desk.refused == 1
    assert desk.book.counts["created"] == 3  # the refused one left no record
    desk.cancel(ids[0])
    fourth = desk.create(PICK)
    assert desk.book.open_count == 3
    assert desk.finish(ids[1], now=1.0)
    desk.create(PICK)
    assert desk.book.open_ids() == [ids[2], fourth, "task-5"]
    assert desk.refused == 1


def test_random_tasks_past_the_limit_are_refused_and_counted() -> None:
    desk = _desk(backlog=2)
    made = [desk.create_random() for _ in range(5)]
    assert made[:2] == ["task-1", "task-2"]
    assert made[2:] == [None, None, None]
    assert desk.refused == 3


def test_a_bad_backlog_is_refused() -> None:
    with pytest.raises(ValueError, match="backlog must be at least 1"):
        _desk(backlog=0)


def test_an_overloaded_fleet_holds_its_backlog_and_reports_the_refused() -> None:
    fleet = Fleet(config=FleetConfig(agvs=4, seed=2, task_interval=1.0))
    fleet.desk.backlog = 12
    most = 0
    for _ in range(60):
        fleet.run(1.0)
        most = max(most, fleet.desk.book.open_count)
    summary = fleet.summary()
    assert most == 12
    assert summary["tasks_refused"] == fleet.desk.refused > 20
    assert summary["tasks_created"] + summary["tasks_refused"] > 30
    assert summary["collisions"] == summary["lock_overlaps"] == 0


def test_a_fleet_at_its_load_is_far_from_the_limit() -> None:
    fleet = Fleet(config=FleetConfig(agvs=20, seed=1, load=0.9))
    fleet.run(300.0)
    assert fleet.summary()["tasks_refused"] == 0
    assert fleet.desk.book.open_count < BACKLOG_LIMIT / 100
