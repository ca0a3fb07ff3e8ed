"""A station: a place where transport tasks appear and are auctioned one at a time.

A station is no node of its own: the fleet's transport base runs every station's
component on its one node (``agv_app.tasks.desk``), so an AGV's properties reach one
listener for all the stations, not one per station. The station queues the tasks that
appear at it and runs a :class:`~agv_app.tasks.TaskAnnouncer` for the oldest, among the
idle AGVs around its own point. It remembers which AGV won each task until that AGV
publishes the task as done (``last_done``); if the winner's node fails first, the task
goes back to the front of the queue (never lost) unless the winner is heard again within
``return_after`` seconds still carrying it: under message loss a live node is now and
then counted as failed (a few beats lost in a row), and giving its task to a second AGV
would have two carry it. One heard again with another task (taken while it dwells at
this task's drop station, before it reports this one done) gets another
``return_after``. Without a bid for ``widen_after`` seconds the auction restarts with
twice the range, and finally with no range limit.

A station calls one AGV at a time (``one_at_a_time``): it starts the auction of its
next task only once every AGV it awarded a task has reached it (``reached_pick``, which
an AGV publishes as it arrives at a pick station) or reported the task done, and no
AGV is on its way to drop a load here (``dropping_at``, the drop station an AGV
publishes as it picks up, cleared as it arrives). Two AGVs bound for one dock queue
for it on the lanes in front of it, and at a dead-end dock the AGV that stands there
leaves through the queue (docs/fleet.md, "A station calls one AGV at a time").

Nor does it call an AGV for a task whose drop station an AGV is bound for already
(``wait_for_drop``), and its next task is its oldest: a station that auctioned a
newer task around a busy drop station sent more AGVs onto lanes that were full. Loads
sent to one drop station by several stations queued for it in its aisle, and the queue
reached back onto the lanes the others need (docs/fleet.md, "A drop station takes one
load at a time").
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Mapping
from typing import Any

from agv_app.geometry import XY
from agv_app.protocol import MessageTally
from agv_app.tasks.auction import TaskAnnouncer, TaskSpec, bidder_group
from objectplaces import RoleActivator, Session

__all__ = ["Station"]


class Station:
    """The task-assignment component of one station.

    Args:
        node: the node that runs it (the transport base's).
        station_id: the layout's station id.
        position: where it stands.
        range_m: first auction range, around ``position``.
        window: bidding window, seconds.
        widen_after: seconds without a bid before the range doubles.
        on_assigned: called with ``(task, agv)`` on every award.
        on_returned: called with ``(task, agv)`` when a task comes back because its
            AGV failed.
        return_after: seconds a failed winner's tasks wait before they go back to the
            queue; a winner heard again by then with the task as its ``task`` keeps it,
            one with another task has one more ``return_after`` to report it done.
        tally: counts protocol messages.
        one_at_a_time: auction the next task only once every winner reached the
            station (or is done, or failed) and no AGV is bound to drop here; False:
            one auction after the other.
        wait_for_drop: with ``one_at_a_time``, also hold the next task while an AGV is
            bound to drop at that task's drop station.
    """

    def __init__(
        self,
        node: RoleActivator,
        station_id: str,
        position: XY,
        *,
        range_m: float = 30.0,
        window: float = 1.5,
        widen_after: float = 10.0,
        on_assigned: Callable[[TaskSpec, str], None] | None = None,
        on_returned: Callable[[TaskSpec, str], None] | None = None,
        return_after: float = 5.0,
        tally: MessageTally | None = None,
        one_at_a_time: bool = True,
        wait_for_drop: bool = True,
    ) -> None:
        self.node = node
        self.one_at_a_time = one_at_a_time
        self.wait_for_drop = wait_for_drop
        self.station_id = station_id
        self.position = position
        self.range_m = range_m
        self.window = window
        self.widen_after = widen_after
        self._on_assigned = on_assigned
        self._on_returned = on_returned
        self.return_after = return_after
        self._tally = tally
        self.queue: deque[TaskSpec] = deque()
        self.assigned: dict[str, tuple[TaskSpec, str]] = {}
        """Tasks awarded and not yet seen done: task id -> (task, winner)."""
        self.returned = 0
        """Tasks put back because their AGV failed."""
        self._session: Session | None = None
        self._announcer: TaskAnnouncer | None = None
        self._range: float | None = range_m
        self._generation = 0
        node.register_node_departure_observer(self._departed)
        node.register_node_property_observer(
            self._property, names=("last_done", "reached_pick", "dropping_at")
        )

    @property
    def current(self) -> TaskSpec | None:
        """The task being auctioned, if any."""
        return None if self._announcer is None else self._announcer.task

    def add_task(self, task: TaskSpec) -> None:
        """Queue a task that appeared here; its auction starts when it is first in line."""
        self.queue.append(task)
        self._next()

    def cancel(self, task_id: str) -> bool:
        """Withdraw a queued task before its award (its auction stops if it runs).

        Returns:
            False if no task ``task_id`` is queued here (awarded already, or unknown).
        """
        task = next((t for t in self.queue if t.id == task_id), None)
        if task is None:
            return False
        self.queue.remove(task)
        announcer, session = self._announcer, self._session
        if announcer is not None and session is not None and announcer.task.id == task_id:
            # Stopping the session cancels its timers: no award can follow.
            self.node.stop_interaction(session)
            self._session = None
            self._announcer = None
            self._generation += 1
            self._next()
        return True

    def adopt(self, task: TaskSpec, agv: str) -> None:
        """Follow ``task`` as awarded to ``agv`` without an auction here: a restarted
        control's desk restores what vehicles held (no ``on_assigned``)."""
        self.queue = deque(t for t in self.queue if t.id != task.id)
        self.assigned[task.id] = (task, agv)
        self.node.call_later(0.0, self._next)

    def release(self, task_id: str) -> bool:
        """Stop following ``task_id``, delivered as far as the desk knows; False if it was
        not awarded here."""
        if self.assigned.pop(task_id, None) is None:
            return False
        self.node.call_later(0.0, self._next)
        return True

    def give_back(self, task_id: str) -> bool:
        """Put ``task_id`` back at the front of the queue: its winner handed it back
        (``on_returned`` is told). False if it was not awarded here."""
        if task_id not in self.assigned:
            return False
        self._put_back(task_id)
        self._next()
        return True

    def _put_back(self, task_id: str) -> None:
        task, agv = self.assigned.pop(task_id)
        self.returned += 1
        self.queue.appendleft(task)
        if self._on_returned is not None:
            self._on_returned(task, agv)

    @property
    def approaching(self) -> tuple[str, ...]:
        """The AGVs on their way here, as this node's view has them: the winners of
        this station's tasks that have not reached it yet, in task order, then the
        AGVs bound to drop here."""
        view = self.node.view()
        winners = tuple(
            agv
            for task_id, (_, agv) in sorted(self.assigned.items())
            if view.get(agv, {}).get("reached_pick") != task_id
        )
        me = self.station_id
        return winners + tuple(
            sorted(n for n, props in view.items() if props.get("dropping_at") == me)
        )

    def _drop_taken(self, drop: str) -> bool:
        """True if this node's view has an AGV bound to drop at ``drop``."""
        return any(props.get("dropping_at") == drop for props in self.node.view().values())

    def _next(self) -> None:
        if self._session is not None or not self.queue:
            return
        if self.one_at_a_time and self.approaching:
            return  # called again as the winner arrives (or is done, or fails)
        if self.one_at_a_time and self.wait_for_drop and self._drop_taken(self.queue[0].drop):
            return  # called again as that AGV arrives (its ``dropping_at`` clears)
        self._range = self.range_m
        self._start(self.queue[0])

    def _start(self, task: TaskSpec) -> None:
        announcer = TaskAnnouncer(
            task, window=self.window, on_awarded=self._awarded, tally=self._tally
        )
        self._announcer = announcer
        self._session = self.node.start_interaction(
            announcer, bidder_group(self._range, self.position), "bidder"
        )
        self._generation += 1
        generation = self._generation
        self.node.call_later(self.widen_after, lambda: self._maybe_widen(generation))

    def _maybe_widen(self, generation: int) -> None:
        announcer, session = self._announcer, self._session
        if generation != self._generation or announcer is None or session is None:
            return
        if announcer.winner is not None or announcer.bids:
            return
        self.node.stop_interaction(session)
        self._range = None if self._range is None or self._range > 200 else self._range * 2
        self._start(announcer.task)

    def _awarded(self, task: TaskSpec, agv: str) -> None:
        self.assigned[task.id] = (task, agv)
        # Not always first in line: a task returned during the auction went before it.
        self.queue = deque(t for t in self.queue if t.id != task.id)
        self._session = None
        self._announcer = None
        if self._on_assigned is not None:
            self._on_assigned(task, agv)
        self.node.call_later(0.0, self._next)

    def _property(self, node_id: str, name: str, value: Any) -> None:
        if name == "dropping_at":
            self.node.call_later(0.0, self._next)
            return
        if not isinstance(value, str):
            return
        entry = self.assigned.get(value)
        if entry is None or entry[1] != node_id:
            return
        if name == "last_done":
            del self.assigned[value]
        # Not from inside the view's update: the winner's other properties may follow.
        self.node.call_later(0.0, self._next)

    def _departed(self, node_id: str, last: Mapping[str, Any]) -> None:
        done = last.get("last_done")
        if isinstance(done, str) and self.assigned.get(done, (None, None))[1] == node_id:
            del self.assigned[done]
        if any(agv == node_id for _, agv in self.assigned.values()):
            self.node.call_later(self.return_after, lambda: self._return_if_gone(node_id))
        # It is on its way here no more (a winner done, or one bound to drop here).
        self.node.call_later(0.0, self._next)

    def _return_if_gone(self, node_id: str, *, patient: bool = True) -> None:
        """Put back the tasks of ``node_id`` unless it is heard again carrying them.

        A winner heard again with another task as its ``task`` may still dwell at
        this task's drop station (it takes the next task there and reports this one
        done when the dwell ends): it gets one more ``return_after`` to report it.
        """
        props = self.node.view().get(node_id)
        carrying = None if props is None else props.get("task")
        wait = False
        for task_id, (_, agv) in sorted(self.assigned.items()):
            if agv != node_id or task_id == carrying:
                continue
            if patient and carrying is not None:
                wait = True
                continue
            self._put_back(task_id)
        if wait:
            self.node.call_later(
                self.return_after, lambda: self._return_if_gone(node_id, patient=False)
            )
        self._next()
