"""The task book: every transport order of a fleet, from creation to its end.

One book serves both fleets (simulated and on the mesh). A task moves through these
states, and the book notes when it last entered each one and which vehicle holds it:

``created``   queued at its pick station, waiting for an award;
``assigned``  awarded to a vehicle, which has not set off for it yet;
``driving``   its vehicle is carrying it out (to the pick station, then the drop);
``done``      delivered (final);
``failed``    its vehicle failed while holding it; the station returns it to its queue
              and awards it again (``assigned`` once more);
``cancelled`` withdrawn before any award (final), or by the master control whose
              order it is.

Most tasks are the desk's. A transport order of a VDA 5050 master control comes with
its vehicle: :meth:`TaskBook.add_held` enters it as ``driving`` at once, with its
``creator``, and it ends ``done`` or, cancelled by its master, ``cancelled``
(:meth:`TaskBook.withdraw`).

Memory stays bounded on runs of any length: the counts of every state entered are
kept for ever, the durations (creation to delivery) as :class:`~agv_app.samples.Samples`
(exact count, mean and maximum; percentiles over the most recent ``keep_times``), the
records of open tasks in full (they are live work, bounded by the station queues), and
the records of finished tasks for the last ``history`` of them only
(:data:`DEFAULT_HISTORY`).

Task ids come back from peers (``last_done`` on the mesh) and may name a task the book
no longer holds in detail; such reports are ignored and say so by returning False.

A book may be written through to a durable store: ``on_change`` hears of every state a
task enters, and :meth:`TaskBook.restore` takes back what a store kept
(:mod:`agv_app.tasks.store`).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Literal, get_args

from agv_app.samples import DEFAULT_KEEP, Samples
from agv_app.tasks.auction import TaskSpec

__all__ = [
    "DEFAULT_HISTORY",
    "FINAL_STATES",
    "HELD_STATES",
    "TASK_STATES",
    "TaskBook",
    "TaskRecord",
    "TaskState",
]

TaskState = Literal["created", "assigned", "driving", "done", "failed", "cancelled"]
"""Where a task stands (see the module docstring)."""

TASK_STATES: tuple[TaskState, ...] = get_args(TaskState)
"""Every state, in the order a task usually passes them."""

DEFAULT_HISTORY = 1000
"""How many finished tasks a book keeps in detail by default."""

FINAL_STATES: frozenset[TaskState] = frozenset({"done", "cancelled"})
"""The states a task ends in."""

HELD_STATES: frozenset[TaskState] = frozenset({"assigned", "driving"})
"""The states in which a vehicle holds a task."""


@dataclass(slots=True)
class TaskRecord:
    """One task as the book knows it.

    Attributes:
        task: what to carry from where to where.
        state: where it stands.
        vehicle: the vehicle that holds or last held it (None before the first award).
        times: when it last entered each state it has passed, seconds.
        creator: who asked for it: ``api`` (a client of the REST API, the page),
            ``auto`` (the fleet's automatic tasks), ``master`` (a VDA 5050 master
            control's transport order); empty when unknown.
    """

    task: TaskSpec
    state: TaskState
    vehicle: str | None = None
    times: dict[TaskState, float] = field(default_factory=dict)
    creator: str = ""

    @property
    def id(self) -> str:
        """The task's id."""
        return self.task.id


class TaskBook:
    """Every transport order of one fleet, with bounded history.

    Args:
        history: how many finished (done or cancelled) tasks to keep in detail.
        keep_times: how many recent task durations to keep for percentiles.
        on_change: called with the record after every state a task enters (its time is
            ``record.times[record.state]``).

    Raises:
        ValueError: ``history`` is negative or ``keep_times`` less than 1.
    """

    def __init__(
        self,
        *,
        history: int = DEFAULT_HISTORY,
        keep_times: int = DEFAULT_KEEP,
        on_change: Callable[[TaskRecord], None] | None = None,
    ) -> None:
        if history < 0:
            raise ValueError(f"history must be 0 or more, got {history!r}")
        self.history = history
        self.on_change = on_change
        """Told of every state a task enters (a durable store writes it through)."""
        self.durations = Samples(keep=keep_times)
        """Seconds from creation to delivery of every task delivered."""
        self.double_assignments = 0
        """Awards of a task that another live vehicle still held (must stay 0)."""
        self._seq = 0
        self._counts: dict[TaskState, int] = dict.fromkeys(TASK_STATES, 0)
        self._open: dict[str, TaskRecord] = {}
        self._finished: OrderedDict[str, TaskRecord] = OrderedDict()

    # -- reading ------------------------------------------------------------------------

    @property
    def counts(self) -> Mapping[TaskState, int]:
        """How often any task entered each state, since the book began."""
        return MappingProxyType(self._counts)

    def get(self, task_id: str) -> TaskRecord | None:
        """The record of ``task_id``: open, or among the last finished ones."""
        return self._open.get(task_id) or self._finished.get(task_id)

    @property
    def open_count(self) -> int:
        """How many tasks are not finished."""
        return len(self._open)

    def open_ids(self) -> list[str]:
        """Ids of the tasks not finished, oldest first."""
        return list(self._open)

    def records(self) -> list[TaskRecord]:
        """The records held: the finished ones kept, then the open ones, oldest first."""
        return [*self._finished.values(), *self._open.values()]

    @property
    def created(self) -> int:
        """How many tasks the book has numbered (the last one is ``task-<created>``)."""
        return self._seq

    def restore(
        self, open_records: Iterable[TaskRecord], finished: Iterable[TaskRecord], *, created: int
    ) -> None:
        """Take back what a durable store kept: the open tasks (oldest first), the last
        finished ones, and how many tasks were numbered, so that no id is used twice.
        ``on_change`` hears nothing of it; the counts and durations stay this run's.

        Raises:
            ValueError: the book holds tasks already, or ``created`` is below a restored
                task's number.
        """
        if self._open or self._finished or self._seq:
            raise ValueError("only an empty book can be restored")
        for record in finished:
            self._remember(record)
        for record in open_records:
            self._open[record.id] = record
        numbers = [_number(r.id) for r in self.records()]
        if numbers and max(numbers) > created:
            raise ValueError(f"task {max(numbers)} restored, but only {created} were created")
        self._seq = created

    # -- transitions --------------------------------------------------------------------

    def create(self, pick: str, drop: str, *, now: float, creator: str = "") -> TaskSpec:
        """A new task from station ``pick`` to station ``drop``, numbered ``task-N``,
        asked for by ``creator``."""
        self._seq += 1
        task = TaskSpec(f"task-{self._seq}", pick, drop)
        record = TaskRecord(task, "created", creator=creator)
        self._open[task.id] = record
        self._enter(record, "created", now)
        return task

    def add_held(self, task: TaskSpec, vehicle: str, *, now: float, creator: str) -> TaskRecord:
        """A task that came with its vehicle (a master control's transport order): it is
        ``driving`` at once, on ``vehicle``.

        Raises:
            ValueError: an open task has that id.
        """
        if task.id in self._open:
            raise ValueError(f"task {task.id!r} is open already")
        record = TaskRecord(task, "created", vehicle=vehicle, creator=creator)
        self._open[task.id] = record
        for state in ("created", "assigned", "driving"):
            self._enter(record, state, now)
        return record

    def withdraw(self, task_id: str, *, now: float) -> bool:
        """The one that gave a held task cancelled it; False unless it is open."""
        record = self._open.get(task_id)
        if record is None:
            return False
        self._enter(record, "cancelled", now)
        self._close(record)
        return True

    def assign(self, task_id: str, vehicle: str, *, now: float) -> bool:
        """``task_id`` was awarded to ``vehicle``; False if the book holds no open task so.

        An award of a task that another vehicle still holds counts as a double
        assignment (the auction promises there is none).
        """
        record = self._open.get(task_id)
        if record is None:
            return False
        if record.state in HELD_STATES and record.vehicle != vehicle:
            self.double_assignments += 1
        record.vehicle = vehicle
        self._enter(record, "assigned", now)
        return True

    def start(self, task_id: str, vehicle: str, *, now: float) -> bool:
        """``vehicle`` set off with ``task_id``; False unless it holds it as assigned."""
        record = self._open.get(task_id)
        if record is None or record.state != "assigned" or record.vehicle != vehicle:
            return False
        self._enter(record, "driving", now)
        return True

    def finish(self, task_id: str, *, now: float) -> bool:
        """``task_id`` was delivered; False if it is not an open task of the book."""
        record = self._open.get(task_id)
        if record is None:
            return False
        self._enter(record, "done", now)
        self.durations.append(now - record.times["created"])
        self._close(record)
        return True

    def fail(self, task_id: str, *, now: float) -> bool:
        """The vehicle holding ``task_id`` failed; False unless a vehicle held it."""
        record = self._open.get(task_id)
        if record is None or record.state not in HELD_STATES:
            return False
        self._enter(record, "failed", now)
        return True

    def cancel(self, task_id: str, *, now: float) -> None:
        """Withdraw ``task_id`` before any vehicle holds it.

        Raises:
            KeyError: the book holds no open task ``task_id``.
            ValueError: a vehicle holds it (``assigned`` or ``driving``).
        """
        record = self._open.get(task_id)
        if record is None:
            raise KeyError(f"no open task {task_id!r}")
        if record.state in HELD_STATES:
            raise ValueError(
                f"task {task_id!r} is {record.state} to {record.vehicle!r}: only a task no "
                "vehicle holds can be cancelled"
            )
        self._enter(record, "cancelled", now)
        self._close(record)

    def _enter(self, record: TaskRecord, state: TaskState, now: float) -> None:
        record.state = state
        record.times[state] = now
        self._counts[state] += 1
        if self.on_change is not None:
            self.on_change(record)

    def _close(self, record: TaskRecord) -> None:
        assert record.state in FINAL_STATES
        del self._open[record.id]
        self._remember(record)

    def _remember(self, record: TaskRecord) -> None:
        if self.history == 0:
            return
        self._finished[record.id] = record
        while len(self._finished) > self.history:
            self._finished.popitem(last=False)


def _number(task_id: str) -> int:
    """The number in a book's task id (``task-N``); 0 for an id of another form."""
    _, _, digits = task_id.rpartition("-")
    return int(digits) if digits.isdigit() else 0
