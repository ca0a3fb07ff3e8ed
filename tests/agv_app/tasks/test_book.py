"""The task book: states and times, counts kept for ever, bounded details."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agv_app.tasks import TASK_STATES, TaskBook, TaskSpec


def test_a_task_passes_every_state_with_its_times_and_vehicle() -> None:
    book = TaskBook()
    task = book.create("pick-1", "drop-1", now=1.0)
    assert task.id == "task-1"
    assert book.assign(task.id, "agv-01", now=2.0)
    assert not book.start(task.id, "agv-02", now=2.5)  # not the vehicle that holds it
    assert book.start(task.id, "agv-01", now=3.0)
    assert book.finish(task.id, now=11.0)
    record = book.get(task.id)
    assert record is not None
    assert record.state == "done"
    assert record.vehicle == "agv-01"
    assert record.times == {"created": 1.0, "assigned": 2.0, "driving": 3.0, "done": 11.0}
    assert book.open_ids() == []
    assert book.durations.count == 1
    assert book.durations.mean == 10.0
    assert dict(book.counts) == {
        "created": 1,
        "assigned": 1,
        "driving": 1,
        "done": 1,
        "failed": 0,
        "cancelled": 0,
    }


def test_counts_are_kept_for_ever_and_details_for_the_last_finished_only() -> None:
    book = TaskBook(history=3)
    ids = [book.create("p", "d", now=float(k)).id for k in range(10)]
    for k, task_id in enumerate(ids):
        book.finish(task_id, now=100.0 + k)
    assert book.counts["created"] == book.counts["done"] == 10
    assert [r.id for r in book.records()] == ids[-3:]
    assert book.get(ids[0]) is None
    assert book.durations.count == 10
    assert book.durations.mean == 100.0  # exact over all ten, not just the kept ones
    assert not book.finish(ids[0], now=200.0)  # a late report of a forgotten task
    assert book.counts["done"] == 10


def test_open_tasks_are_never_forgotten() -> None:
    book = TaskBook(history=0)
    old = book.create("p", "d", now=0.0).id
    for k in range(5):
        book.finish(book.create("p", "d", now=1.0).id, now=2.0 + k)
    assert book.open_ids() == [old]
    assert book.records() == [book.get(old)]
    assert book.finish(old, now=50.0)
    assert book.durations.maximum == 50.0


def test_a_task_whose_vehicle_failed_is_awarded_again_without_a_double_assignment() -> None:
    book = TaskBook()
    task_id = book.create("p", "d", now=0.0).id
    book.assign(task_id, "agv-01", now=1.0)
    book.start(task_id, "agv-01", now=2.0)
    assert not book.fail("task-99", now=3.0)
    assert book.fail(task_id, now=3.0)
    assert not book.fail(task_id, now=3.5)  # nobody holds it now
    book.assign(task_id, "agv-02", now=4.0)
    assert book.double_assignments == 0
    book.assign(task_id, "agv-03", now=5.0)  # agv-02 still holds it
    assert book.double_assignments == 1
    assert book.counts["failed"] == 1
    assert book.counts["assigned"] == 3


def test_only_a_task_no_vehicle_holds_can_be_cancelled() -> None:
    book = TaskBook()
    waiting = book.create("p", "d", now=0.0).id
    held = book.create("p", "d", now=0.0).id
    book.assign(held, "agv-07", now=1.0)
    book.cancel(waiting, now=2.0)
    record = book.get(waiting)
    assert record is not None
    assert record.state == "cancelled"
    assert book.open_ids() == [held]
    with pytest.raises(ValueError, match=r"'task-2' is assigned to 'agv-07'"):
        book.cancel(held, now=3.0)
    with pytest.raises(KeyError, match="task-1"):
        book.cancel(waiting, now=3.0)
    with pytest.raises(ValueError, match="history must be 0 or more, got -1"):
        TaskBook(history=-1)


_OPS = st.lists(
    st.tuples(
        st.sampled_from(["create", "assign", "start", "finish", "fail", "cancel"]),
        st.integers(0, 30),
        st.sampled_from(["agv-1", "agv-2"]),
    ),
    max_size=120,
)


@settings(max_examples=60, deadline=None)
@given(ops=_OPS, history=st.integers(0, 5))
def test_counts_match_the_transitions_and_memory_stays_bounded(
    ops: list[tuple[str, int, str]], history: int
) -> None:
    book = TaskBook(history=history)
    entered = dict.fromkeys(TASK_STATES, 0)
    open_ids: list[str] = []
    now = 0.0
    for op, k, agv in ops:
        now += 1.0
        task_id = f"task-{k}"
        before = book.get(task_id)
        state = None if before is None else before.state
        if op == "create":
            open_ids.append(book.create("p", "d", now=now).id)
            entered["created"] += 1
        elif op == "assign":
            entered["assigned"] += book.assign(task_id, agv, now=now)
        elif op == "start":
            entered["driving"] += book.start(task_id, agv, now=now)
        elif op == "finish":
            if book.finish(task_id, now=now):
                entered["done"] += 1
                open_ids.remove(task_id)
        elif op == "fail":
            entered["failed"] += book.fail(task_id, now=now)
        elif task_id in open_ids and state not in ("assigned", "driving"):
            book.cancel(task_id, now=now)
            entered["cancelled"] += 1
            open_ids.remove(task_id)
        assert dict(book.counts) == entered
        assert book.open_ids() == open_ids
        assert len(book.records()) <= history + len(open_ids)
    assert book.durations.count == entered["done"]


def test_a_task_that_comes_with_its_vehicle_is_driving_at_once() -> None:
    book = TaskBook()
    record = book.add_held(TaskSpec("m-1", "p", "d"), "agv-01", now=2.0, creator="master")
    assert (record.state, record.vehicle, record.creator) == ("driving", "agv-01", "master")
    assert record.times == {"created": 2.0, "assigned": 2.0, "driving": 2.0}
    with pytest.raises(ValueError, match="open already"):
        book.add_held(TaskSpec("m-1", "p", "d"), "agv-02", now=3.0, creator="master")
    assert book.finish("m-1", now=9.0)
    book.add_held(TaskSpec("m-2", "p", "d"), "agv-01", now=10.0, creator="master")
    assert book.withdraw("m-2", now=11.0)
    assert not book.withdraw("m-2", now=12.0)
    assert [r.state for r in book.records()] == ["done", "cancelled"]
    assert book.double_assignments == 0
