"""What a task desk needs of a durable store: the small interface between the desk (a
compiled module, no I/O of its own) and :class:`~agv_app.tasks.store.OrderStore`
(SQLite, interpreted).
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Protocol

from agv_app.tasks.book import TaskRecord

__all__ = ["StoredTasks", "TaskJournal"]


@dataclass(frozen=True, slots=True)
class StoredTasks:
    """What a store kept of a task book.

    Attributes:
        open: the tasks not finished, oldest first, their times on the clock given.
        finished: the last finished ones, in the order they finished.
        created: how many tasks were ever numbered (the next is ``task-<created + 1>``).
    """

    open: tuple[TaskRecord, ...]
    finished: tuple[TaskRecord, ...]
    created: int


class TaskJournal(Protocol):
    """A durable store of a task book's changes."""

    def restore_tasks(self, clock: Callable[[], float], *, finished: int) -> StoredTasks:
        """What the store kept, with times on ``clock`` (the fleet's), and at most
        ``finished`` finished tasks; later times written are on ``clock`` too."""
        ...

    def task_changed(self, record: TaskRecord) -> None:
        """``record`` entered ``record.state`` at ``record.times[record.state]``: write it
        (a task not seen before is added)."""
        ...

    def task_queued(self, task_id: str, now: float) -> None:
        """The desk handed ``task_id`` to its station at ``now``."""
        ...

    def transaction(self) -> AbstractContextManager[None]:
        """The writes within are committed together (nested ones join the outer one)."""
        ...
