"""The desk keeps the tasks on the floor to ``max_open``: the rest wait at the desk and
go to their stations oldest first, as tasks are done or cancelled."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from agv_app.fleet import Fleet, FleetConfig
from agv_app.tasks.auction import TaskSpec
from agv_app.tasks.desk import TaskDesk
from objectplaces.cli import main
from tests.agv_app.tasks.desks import demo_desk

PICK = "dock-in-1"


def _desk(max_open: int | None) -> TaskDesk:
    return demo_desk(max_open=max_open)[0]


def _at_stations(desk: TaskDesk) -> list[str]:
    """Ids of the tasks the stations hold (queued, or being auctioned), oldest first."""
    return sorted(
        (t.id for s in desk.stations.values() for t in s.queue), key=lambda i: int(i.split("-")[1])
    )


def test_tasks_beyond_the_limit_wait_at_the_desk_and_go_out_oldest_first() -> None:
    desk = _desk(max_open=2)
    ids = [desk.create(PICK, "dock-out-1") for _ in range(3)]
    ids += [desk.create("pick-A1-1", "dock-out-2") for _ in range(2)]
    assert _at_stations(desk) == ids[:2]
    assert desk.waiting == 3
    assert desk.book.counts["created"] == 5
    desk.cancel(ids[1])  # queued at its station: cancelled there, the oldest waiting goes
    assert _at_stations(desk) == [ids[0], ids[2]]
    desk.cancel(ids[4])  # still at the desk: it never reaches its station
    assert desk.waiting == 1
    assert _at_stations(desk) == [ids[0], ids[2]]
    desk.cancel(ids[0])  # being auctioned: the auction stops, the last one waiting goes
    assert _at_stations(desk) == [ids[2], ids[3]]
    assert desk.waiting == 0
    assert desk.book.counts["cancelled"] == 3


def test_without_a_limit_every_task_goes_to_its_station_at_once() -> None:
    desk = _desk(max_open=None)
    ids = [desk.create(PICK) for _ in range(30)]
    assert _at_stations(desk) == ids
    assert desk.waiting == 0


@pytest.mark.parametrize("bad", [0, -3, True])
def test_a_limit_below_one_is_refused(bad: int) -> None:
    with pytest.raises(ValueError, match="max_open must be a whole number >= 1"):
        _desk(max_open=bad)


def test_a_fleet_never_has_more_tasks_on_the_floor_than_its_limit() -> None:
    limit = 3
    fleet = Fleet(None, FleetConfig(agvs=8, seed=2, load=1.0, max_open_tasks=limit))
    book, most = fleet.desk.book, 0
    for _ in range(round(480 / fleet.config.dt)):
        fleet.step()
        on_floor = len(book.open_ids()) - fleet.desk.waiting
        assert on_floor <= limit, f"t={fleet.now:.1f}: {on_floor} tasks on the floor"
        most = max(most, on_floor)
    figures = fleet.summary()
    assert most == limit  # the load asks for more: the limit is what holds them back
    assert fleet.desk.waiting > 0
    # Each delivery hands out the next: far more than the limit are done in the run.
    assert figures["tasks_completed"] >= 3 * limit
    assert figures["collisions"] == figures["lock_overlaps"] == 0


def test_the_cli_refuses_a_limit_below_one(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--agvs", "2", "--minutes", "1", "--max-open-tasks", "0", "--quiet"]) == 2
    assert "--max-open-tasks must be at least 1; got 0" in capsys.readouterr().err


_STATIONS = ("dock-in-1", "dock-in-2", "pick-A1-1")


@settings(max_examples=60, deadline=None)
@given(
    limit=st.integers(1, 4),
    ops=st.lists(
        st.tuples(st.sampled_from(("create", "cancel", "finish")), st.integers(0, 40)),
        max_size=40,
    ),
)
# A task finished while it still waited at the desk stayed in its queue.
@pytest.mark.source_only("replaces Station.add_task")
@example(limit=1, ops=[("create", 0), ("create", 0), ("finish", 1)])
def test_the_limit_holds_and_tasks_go_out_in_creation_order(
    limit: int, ops: list[tuple[str, int]]
) -> None:
    desk = _desk(max_open=limit)
    handed: list[str] = []  # every task that reached a station, in that order
    for station in desk.stations.values():
        add = station.add_task

        def watched(task: TaskSpec, add: Callable[[TaskSpec], None] = add) -> None:
            handed.append(task.id)
            add(task)

        station.add_task = watched  # type: ignore[method-assign]
    created: list[str] = []
    closed: set[str] = set()
    for op, n in ops:
        if op == "create":
            created.append(desk.create(_STATIONS[n % len(_STATIONS)]))
            continue
        live = [t for t in created if t not in closed]
        if not live:
            continue
        task = live[n % len(live)]
        if op == "cancel":
            desk.cancel(task)
        else:
            desk.book.assign(task, "agv-1", now=0.0)
            assert desk.finish(task, now=0.0)
        closed.add(task)
        on_floor = [t for t in handed if t not in closed]
        assert len(on_floor) <= limit
        # Nothing waits while there is room, and nothing is lost.
        assert desk.waiting == 0 or len(on_floor) == limit
        assert len(on_floor) + desk.waiting == len(created) - len(closed)
    # Tasks reach their stations in the order they were created (skipping any
    # cancelled while they waited at the desk).
    assert handed == [t for t in created if t in handed]
    assert len(set(handed)) == len(handed)
