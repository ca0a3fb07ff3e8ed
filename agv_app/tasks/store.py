"""The durable order book: transport orders, their states and the operator's event log in
one SQLite file, owned by one control process.

Layout (schema version :data:`SCHEMA_VERSION`, also in the file header's application id)::

    meta    key -> value: schema, created (tasks ever numbered), holder (pid)
    tasks   one row per task: n (order created), id, pick, drop_at, creator, state,
            vehicle, history (JSON list of [state, time, vehicle]), closed (order
            finished; NULL while open)
    events  seq, time, severity, source, text: the event log

**Write-through.** Every state a task enters is written before the desk's call returns,
in a transaction of its own or in one the desk opens around a whole operation
(``transaction``); an order a client was told of is on disk. An award is written before
its message leaves the process: a role's ``send`` only queues the frame, which the
runtime writes out after the callback that awarded (and wrote) returns.

**Durability.** WAL with ``synchronous=FULL``: every commit waits for the log to reach the
disk. ``NORMAL`` would be enough for a SIGKILL (a commit is in the kernel's page cache
once ``write`` returns, and the kernel outlives the process), but not for a power cut or
a kernel crash, which may lose the last commits; a client that was told its order was
taken does not send it again. The price is one fsync per change, a few a second at a
fleet's pace.

**Ownership and refusals** (:mod:`agv_app.tasks.store_file`): one control per file (a
second one is told the holder's pid); a file that is not a whole order store of this
schema version is refused with :class:`StoreError`, never started afresh: only a
missing file is.

**Times** are kept as wall-clock (Unix) seconds and converted to and from the fleet's
clock (``use_clock``), which starts at zero in each run: a task restored from an earlier
run was created at a negative time, and its duration counts the time the control was down.

**Bounds.** Open tasks are few (the desk's backlog); finished tasks beyond
``keep_finished`` and events beyond ``keep_events`` are pruned, oldest first.
"""

from __future__ import annotations

import json
import os
import sqlite3
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType
from typing import Any

from agv_app.tasks.book import FINAL_STATES, TaskRecord
from agv_app.tasks.journal import StoredTasks
from agv_app.tasks.store_file import (
    APPLICATION_ID,
    SCHEMA_VERSION,
    StoreError,
    connect,
    lock,
    unlock,
)
from agv_app.tasks.store_rows import append_history, row_item, task_number, task_record

__all__ = [
    "APPLICATION_ID",
    "DEFAULT_KEEP_EVENTS",
    "DEFAULT_KEEP_FINISHED",
    "SCHEMA_VERSION",
    "OrderStore",
    "StoreError",
    "StoredEvent",
]

DEFAULT_KEEP_FINISHED = 10_000
"""Finished tasks a store keeps, newest; older ones are pruned."""

DEFAULT_KEEP_EVENTS = 50_000
"""Events a store keeps, newest; older ones are pruned."""

StoredEvent = tuple[int, float, str, str, str]
"""An event as kept: seq, time (on the store's clock), severity, source, text."""


class OrderStore:
    """Transport orders and the event log of one fleet, in SQLite; made by :meth:`open`.

    It is a :class:`~agv_app.tasks.journal.TaskJournal` for a
    :class:`~agv_app.tasks.desk.TaskDesk` and an event store for the dashboard's
    ``EventLog``. Touched from one thread at a time (the control's event loop).
    """

    def __init__(
        self,
        path: Path,
        db: sqlite3.Connection,
        lock_fd: int,
        *,
        keep_finished: int,
        keep_events: int,
        wall: Callable[[], float],
    ) -> None:
        self.path = path
        self._db: sqlite3.Connection | None = db
        self._lock_fd: int | None = lock_fd
        self.keep_finished = keep_finished
        self.keep_events = keep_events
        self._wall = wall
        self._clock: Callable[[], float] | None = None
        self._depth = 0
        self._created = int(self._meta("created"))
        row = db.execute("SELECT coalesce(max(closed), 0) FROM tasks").fetchone()
        self._closed = int(row[0])
        self._history: dict[str, list[list[Any]]] = {
            task_id: json.loads(history)
            for task_id, history in db.execute(
                "SELECT id, history FROM tasks WHERE closed IS NULL ORDER BY n"
            )
        }
        """The history of every open task, as written (appended to on each change)."""

    # -- opening and closing ----------------------------------------------------------

    @classmethod
    def open(
        cls,
        path: str | os.PathLike[str],
        *,
        keep_finished: int = DEFAULT_KEEP_FINISHED,
        keep_events: int = DEFAULT_KEEP_EVENTS,
        busy_timeout: float = 2.0,
        wall: Callable[[], float] = time.time,
    ) -> OrderStore:
        """Open the store at ``path`` for this process alone, making it if it is missing.

        Args:
            path: the database file; ``<path>.lock`` beside it marks its owner.
            keep_finished: finished tasks kept (at least 1).
            keep_events: events kept (at least 1).
            busy_timeout: seconds to wait for a lock another process holds on the file.
            wall: the wall clock, seconds.

        Raises:
            StoreError: another control holds it (named by pid), another process locks
                it, it is no SQLite file, no order store, damaged or of another schema
                version, a write-ahead log is there without it, or it cannot be made.
            ValueError: ``keep_finished`` or ``keep_events`` below 1.
        """
        if keep_finished < 1 or keep_events < 1:
            raise ValueError(
                f"keep_finished and keep_events must be at least 1, "
                f"got {keep_finished!r} and {keep_events!r}"
            )
        path = Path(path)
        lock_fd = lock(path)
        try:
            db = connect(path, busy_timeout)
        except BaseException:
            unlock(lock_fd)
            raise
        try:
            return cls(
                path,
                db,
                lock_fd,
                keep_finished=keep_finished,
                keep_events=keep_events,
                wall=wall,
            )
        except BaseException as exc:
            db.close()
            unlock(lock_fd)
            if isinstance(exc, sqlite3.Error | ValueError):  # a row not as written
                raise StoreError(f"order store {path} is damaged ({exc})") from None
            raise

    @property
    def closed(self) -> bool:
        """True once :meth:`close` ran."""
        return self._db is None

    def close(self) -> None:
        """Close the file and give up ownership (idempotent)."""
        db, self._db = self._db, None
        if db is not None:
            db.close()  # the last connection: SQLite checkpoints and removes the log
        fd, self._lock_fd = self._lock_fd, None
        if fd is not None:
            unlock(fd)

    def __enter__(self) -> OrderStore:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"OrderStore({str(self.path)!r}{', closed' if self.closed else ''})"

    # -- time --------------------------------------------------------------------------

    def use_clock(self, clock: Callable[[], float]) -> None:
        """Convert times to and from ``clock`` (the fleet's) from now on; without one,
        times are kept as given."""
        self._clock = clock

    def _offset(self) -> float:
        """Wall-clock seconds at the clock's zero."""
        return 0.0 if self._clock is None else self._wall() - self._clock()

    # -- writing -------------------------------------------------------------------------

    @contextmanager
    def transaction(self) -> Iterator[None]:
        """Commit the writes within together (a nested one joins the outer one).

        Raises:
            StoreError: the store is closed, or SQLite cannot write (disk full ...).
        """
        db = self._connection()
        if self._depth:
            self._depth += 1
            try:
                yield
            finally:
                self._depth -= 1
            return
        try:
            db.execute("BEGIN IMMEDIATE")
        except sqlite3.Error as exc:
            raise self._failed(exc) from exc
        self._depth = 1
        try:
            yield
        except BaseException:
            self._depth = 0
            db.execute("ROLLBACK")
            raise
        self._depth = 0
        try:
            db.execute("COMMIT")
        except sqlite3.Error as exc:
            raise self._failed(exc) from exc

    def _execute(self, sql: str, args: tuple[Any, ...] = ()) -> sqlite3.Cursor:
        try:
            return self._connection().execute(sql, args)
        except sqlite3.Error as exc:
            raise self._failed(exc) from exc

    def _failed(self, exc: sqlite3.Error) -> StoreError:
        return StoreError(f"order store {self.path}: cannot write: {exc}")

    def _connection(self) -> sqlite3.Connection:
        if self._db is None:
            raise StoreError(f"order store {self.path} is closed")
        return self._db

    def _meta(self, key: str) -> str:
        row = self._connection().execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
        if row is None:
            raise StoreError(f"order store {self.path} is damaged: no {key!r} in its meta table")
        return str(row[0])

    # -- tasks (TaskJournal) -----------------------------------------------------------

    def task_changed(self, record: TaskRecord) -> None:
        """Write the state ``record`` entered (see ``TaskJournal``).

        Raises:
            StoreError: the store is closed or cannot write.
        """
        state = record.state
        entry = [state, self._wall_time(record.times[state]), record.vehicle]
        closed = state in FINAL_STATES
        with self.transaction():
            history = self._history.get(record.id)
            if history is None:
                history = [
                    [s, self._wall_time(t), record.vehicle]
                    for s, t in sorted(record.times.items(), key=lambda kv: kv[1])
                ]
                self._history[record.id] = history
                self._execute(
                    "INSERT INTO tasks (id, pick, drop_at, creator, state, vehicle, history) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (
                        record.id,
                        record.task.pick,
                        record.task.drop,
                        record.creator,
                        state,
                        record.vehicle,
                        "[]",
                    ),
                )
                self._created = max(self._created + 1, task_number(record.id))
                self._execute(
                    "UPDATE meta SET value = ? WHERE key = 'created'", (str(self._created),)
                )
            else:
                append_history(history, entry)
            closing = None
            if closed:
                self._closed += 1
                closing = self._closed
                del self._history[record.id]
            self._execute(
                "UPDATE tasks SET state = ?, vehicle = ?, history = ?, closed = ? WHERE id = ?",
                (state, record.vehicle, json.dumps(history), closing, record.id),
            )
            if closing is not None and closing > self.keep_finished:
                self._execute(
                    "DELETE FROM tasks WHERE closed <= ?", (closing - self.keep_finished,)
                )

    def task_queued(self, task_id: str, now: float) -> None:
        """Note that the desk handed ``task_id`` to its station (history only).

        Raises:
            StoreError: the store is closed or cannot write.
        """
        history = self._history.get(task_id)
        if history is None:
            return
        append_history(history, ["queued", self._wall_time(now), None])
        with self.transaction():
            self._execute(
                "UPDATE tasks SET history = ? WHERE id = ?", (json.dumps(history), task_id)
            )

    def restore_tasks(self, clock: Callable[[], float], *, finished: int) -> StoredTasks:
        """The open tasks, oldest first, and the last ``finished`` finished ones, times on
        ``clock``, which the store uses from now on (``use_clock``).

        Raises:
            StoreError: the store is closed, or a row is not one this module wrote.
        """
        self.use_clock(clock)
        offset = self._offset()
        rows = self._execute(
            "SELECT id, pick, drop_at, creator, state, vehicle, history FROM tasks "
            "WHERE closed IS NULL ORDER BY n"
        ).fetchall()
        done = self._execute(
            "SELECT id, pick, drop_at, creator, state, vehicle, history FROM tasks "
            "WHERE closed IS NOT NULL ORDER BY closed DESC LIMIT ?",
            (finished,),
        ).fetchall()
        return StoredTasks(
            open=tuple(task_record(row, offset, self.path) for row in rows),
            finished=tuple(task_record(row, offset, self.path) for row in reversed(done)),
            created=self._created,
        )

    def task_rows(self) -> list[dict[str, Any]]:
        """Every task kept, oldest first, as written: id, pick, drop, creator, state,
        vehicle, history (``[state, wall-clock seconds, vehicle]`` entries), closed."""
        rows = self._execute(
            "SELECT id, pick, drop_at, creator, state, vehicle, history, closed FROM tasks "
            "ORDER BY n"
        ).fetchall()
        return [row_item(row) for row in rows]

    def _wall_time(self, t: float) -> float:
        return round(t + self._offset(), 6)

    # -- events (the dashboard's EventStore) ---------------------------------------------

    def add_event(self, seq: int, time: float, severity: str, source: str, text: str) -> None:
        """Keep one event of the log (``time`` on the store's clock); the oldest beyond
        ``keep_events`` go.

        Raises:
            StoreError: the store is closed or cannot write.
        """
        with self.transaction():
            self._execute(
                "INSERT OR REPLACE INTO events (seq, time, severity, source, text) "
                "VALUES (?, ?, ?, ?, ?)",
                (seq, self._wall_time(time), severity, source, text),
            )
            if seq >= self.keep_events:
                self._execute("DELETE FROM events WHERE seq <= ?", (seq - self.keep_events,))

    def recent_events(self, limit: int) -> list[StoredEvent]:
        """The last ``limit`` events kept, oldest first, times on the store's clock."""
        offset = self._offset()
        rows = self._execute(
            "SELECT seq, time, severity, source, text FROM events ORDER BY seq DESC LIMIT ?",
            (limit,),
        ).fetchall()
        return [(int(s), float(t) - offset, str(v), str(o), str(x)) for s, t, v, o, x in rows][::-1]
