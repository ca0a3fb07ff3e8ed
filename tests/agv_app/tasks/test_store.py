"""The order store: its schema, write-through, what it gives back, and what it refuses."""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path

import pytest

from agv_app.tasks.book import TaskBook
from agv_app.tasks.store import (
    APPLICATION_ID,
    SCHEMA_VERSION,
    OrderStore,
    StoreError,
)


class Clock:
    """A fleet clock the test sets, and a wall clock 1000 s ahead of it."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def wall(self) -> float:
        return 1000.0 + self.now


def written_book(store: OrderStore, clock: Clock) -> TaskBook:
    store.use_clock(clock)
    return TaskBook(on_change=store.task_changed)


def test_a_missing_file_is_made_whole_with_its_schema(tmp_path: Path) -> None:
    path = tmp_path / "orders.db"
    with OrderStore.open(path) as store:
        assert store.path == path
        assert (tmp_path / "orders.db.lock").read_text() == f"{os.getpid()}\n"
    assert not (tmp_path / "orders.db.new").exists()
    db = sqlite3.connect(path)
    try:
        tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        assert tables == {"meta", "tasks", "events"}
        assert db.execute("PRAGMA application_id").fetchone() == (APPLICATION_ID,)
        assert db.execute("PRAGMA journal_mode").fetchone() == ("wal",)
        meta = dict(db.execute("SELECT key, value FROM meta"))
        assert meta["schema"] == str(SCHEMA_VERSION)
        assert meta["holder"] == str(os.getpid())
    finally:
        db.close()


def test_every_change_is_written_through_with_its_history(tmp_path: Path) -> None:
    clock = Clock()
    store = OrderStore.open(tmp_path / "orders.db", wall=clock.wall)
    book = written_book(store, clock)
    task = book.create("dock-in-1", "dock-out-1", now=0.0, creator="api")
    clock.now = 1.5
    store.task_queued(task.id, 1.5)
    book.assign(task.id, "agv-1", now=2.0)
    book.start(task.id, "agv-1", now=3.0)
    (row,) = store.task_rows()
    assert row == {
        "id": "task-1",
        "pick": "dock-in-1",
        "drop": "dock-out-1",
        "creator": "api",
        "state": "driving",
        "vehicle": "agv-1",
        "history": [
            ["created", 1000.0, None],
            ["queued", 1001.5, None],
            ["assigned", 1002.0, "agv-1"],
            ["driving", 1003.0, "agv-1"],
        ],
        "closed": None,
    }
    book.finish(task.id, now=4.0)
    (row,) = store.task_rows()
    assert (row["state"], row["closed"]) == ("done", 1)
    store.close()


def test_a_reopened_store_gives_back_open_and_finished_tasks_on_the_new_clock(
    tmp_path: Path,
) -> None:
    clock = Clock()
    path = tmp_path / "orders.db"
    store = OrderStore.open(path, wall=clock.wall)
    book = written_book(store, clock)
    ids = [book.create("p", f"d{i}", now=0.0, creator="auto").id for i in range(4)]
    clock.now = 10.0
    book.assign(ids[1], "agv-1", now=10.0)
    book.cancel(ids[2], now=10.0)
    book.assign(ids[3], "agv-2", now=10.0)
    book.fail(ids[3], now=10.0)
    store.close()

    later = Clock()
    later.now = 0.0
    store = OrderStore.open(path, wall=lambda: 1100.0)  # 90 s after the last change
    stored = store.restore_tasks(later, finished=10)
    assert [(r.id, r.state, r.vehicle) for r in stored.open] == [
        ("task-1", "created", None),
        ("task-2", "assigned", "agv-1"),
        ("task-4", "failed", "agv-2"),
    ]
    assert stored.open[1].times == {"created": -100.0, "assigned": -90.0}
    assert stored.open[0].creator == "auto"
    assert [(r.id, r.state) for r in stored.finished] == [("task-3", "cancelled")]
    assert stored.created == 4
    book = TaskBook(on_change=store.task_changed)
    book.restore(stored.open, stored.finished, created=stored.created)
    assert book.create("p", "d", now=0.0).id == "task-5"  # no id is used twice
    store.close()


def test_finished_tasks_and_events_beyond_the_limits_are_pruned(tmp_path: Path) -> None:
    clock = Clock()
    store = OrderStore.open(tmp_path / "orders.db", keep_finished=2, keep_events=3, wall=clock.wall)
    book = written_book(store, clock)
    ids = [book.create("p", "d", now=0.0).id for _ in range(5)]
    for task_id in ids[:4]:
        book.cancel(task_id, now=1.0)
    assert [r["id"] for r in store.task_rows()] == ["task-3", "task-4", "task-5"]
    for seq in range(5):
        store.add_event(seq, float(seq), "info", "fleet", f"event {seq}")
    assert [e[0] for e in store.recent_events(10)] == [2, 3, 4]
    assert store.recent_events(2)[-1] == (4, 4.0, "info", "fleet", "event 4")
    store.close()
    with pytest.raises(ValueError, match="at least 1"):
        OrderStore.open(tmp_path / "other.db", keep_events=0)


def test_a_second_opener_is_refused_naming_the_path_and_the_holders_pid(tmp_path: Path) -> None:
    path = tmp_path / "orders.db"
    first = OrderStore.open(path)
    with pytest.raises(StoreError) as refused:
        OrderStore.open(path)
    message = str(refused.value)
    assert str(path) in message
    assert f"in use by another control (pid {os.getpid()})" in message
    first.close()
    OrderStore.open(path).close()  # free again once closed


def test_a_file_locked_by_another_process_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "orders.db"
    OrderStore.open(path).close()
    other = sqlite3.connect(path, isolation_level=None)
    other.execute("PRAGMA locking_mode = EXCLUSIVE")
    other.execute("BEGIN EXCLUSIVE")
    try:
        with pytest.raises(StoreError, match=rf"{path} is locked by another process"):
            OrderStore.open(path, busy_timeout=0.1)
    finally:
        other.execute("ROLLBACK")
        other.close()


@pytest.mark.parametrize(
    ("content", "why"),
    [
        (b"this is no database at all, " * 100, "is not an SQLite database"),
        (b"", "is an empty file"),
    ],
)
def test_a_file_that_is_no_sqlite_database_is_refused(
    tmp_path: Path, content: bytes, why: str
) -> None:
    path = tmp_path / "orders.db"
    path.write_bytes(content)
    with pytest.raises(StoreError, match=f"order store {path} {why}"):
        OrderStore.open(path)
    assert path.read_bytes() == content  # untouched: never a silent fresh start


def test_another_sqlite_database_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "orders.db"
    db = sqlite3.connect(path)
    db.execute("CREATE TABLE t (x)")
    db.commit()
    db.close()
    with pytest.raises(StoreError, match="is an SQLite database but no order store"):
        OrderStore.open(path)


def test_a_store_of_another_schema_version_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "orders.db"
    OrderStore.open(path).close()
    db = sqlite3.connect(path)
    db.execute("UPDATE meta SET value = '99' WHERE key = 'schema'")
    db.commit()
    db.close()
    with pytest.raises(StoreError, match=r"has schema version 99; this program reads version 1"):
        OrderStore.open(path)


def test_a_damaged_store_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "orders.db"
    clock = Clock()
    store = OrderStore.open(path)
    book = written_book(store, clock)
    for _ in range(300):  # a few pages of tasks and their index
        book.create("dock-in-1", "dock-out-1", now=0.0)
    store.close()
    data = bytearray(path.read_bytes())
    page = 4096
    assert len(data) > 3 * page
    data[page + 100 : 3 * page] = b"\xff" * (2 * page - 100)  # a torn write, say
    path.write_bytes(bytes(data))
    with pytest.raises(StoreError, match=rf"order store {path} is damaged"):
        OrderStore.open(path)


def test_a_write_ahead_log_without_its_store_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "orders.db"
    (tmp_path / "orders.db-wal").write_bytes(b"left over")
    with pytest.raises(StoreError, match="is missing but its write-ahead log"):
        OrderStore.open(path)
    assert not path.exists()


def test_a_store_in_a_missing_folder_is_refused(tmp_path: Path) -> None:
    with pytest.raises(StoreError, match="no folder"):
        OrderStore.open(tmp_path / "nowhere" / "orders.db")


def test_a_closed_store_refuses_writes(tmp_path: Path) -> None:
    store = OrderStore.open(tmp_path / "orders.db")
    store.close()
    store.close()
    assert store.closed
    with pytest.raises(StoreError, match="is closed"):
        store.add_event(0, 0.0, "info", "fleet", "late")


def test_a_store_with_a_row_not_as_written_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "orders.db"
    store = OrderStore.open(path)
    TaskBook(on_change=store.task_changed).create("p", "d", now=0.0)
    store.close()
    db = sqlite3.connect(path)
    db.execute("UPDATE tasks SET history = '[oops'")
    db.commit()
    db.close()
    with pytest.raises(StoreError, match=rf"order store {path} is damaged"):
        OrderStore.open(path)
