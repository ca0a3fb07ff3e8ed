"""The task desk: a fleet's stations and its task book, behind one ``create_task``.

Both fleets (simulated and on the mesh) run one *transport base* (node id
:data:`BASE_ID`), whose node runs the task assignment of every usable pick station, and
create tasks the same way: at a pick station, to a drop station drawn at
random unless given, numbered by the :class:`~agv_app.tasks.book.TaskBook`. The desk
does that once for both; the stations report awards and returns into the book, and the
fleet reports starts and deliveries, which it learns from its vehicles.

A desk may keep the tasks on the floor to a number (``max_open``): a task created
while that many are open (handed to their stations and not yet done) waits at the
desk and goes to its station, in the order created, when one is done or cancelled.
A floor carries only so many moving AGVs: past that, more tasks at once only fill its
lanes and each AGV waits longer than it drives (docs/fleet.md, "More AGVs than the
floor carries"); held at the desk, they wait without taking a lane. ``max_open="auto"``
lets the limit follow the floor (:class:`~agv_app.tasks.admission.AdaptiveLimit`): the
fleet tells the desk of every long wait (:meth:`TaskDesk.long_wait`).

The desk follows who holds each task it handed out (:mod:`agv_app.tasks.custody`, fed
by :mod:`agv_app.tasks.custody_watch`): it closes a task a vehicle reports done
(``last_done``) and has the station give back one its vehicle no longer holds (the
vehicle says ``returned``, or has not named it as its ``task`` for ``hand_back_after``
seconds). A task is auctioned again only then, or when its vehicle's node fails.

With a durable store (``store``, :class:`~agv_app.tasks.store.OrderStore`) every state a
task enters is written through, and a new desk on the same store resumes every open task:
those no vehicle held wait at the desk again, oldest first, and go to their stations as
these open; those a vehicle held stay with it (never auctioned twice) until it reports
them done or hands them back (docs/fleet.md, "The order book").
"""

from __future__ import annotations

import random
from collections import deque
from collections.abc import Callable, Iterable

from agv_app.layout.graph import Layout
from agv_app.protocol import BASE_KIND, MessageTally
from agv_app.tasks.admission import AdaptiveLimit, carried_tasks
from agv_app.tasks.auction import TaskSpec
from agv_app.tasks.book import DEFAULT_HISTORY, HELD_STATES, TaskBook, TaskRecord
from agv_app.tasks.custody import (
    DEFAULT_HAND_BACK_AFTER,
    CustodyMachine,
    Delivered,
    Verdict,
)
from agv_app.tasks.custody_watch import CustodyWatch
from agv_app.tasks.journal import TaskJournal
from agv_app.tasks.limits import BACKLOG_LIMIT, BacklogFull, check_max_open, parse_max_open
from agv_app.tasks.station import Station
from agv_app.tasks.stations import BASE_ID, drop_stations, pick_stations, require_task_stations
from objectplaces import RoleActivator

__all__ = [
    "BACKLOG_LIMIT",
    "BASE_ID",
    "BacklogFull",
    "TaskDesk",
    "check_max_open",
    "drop_stations",
    "parse_max_open",
    "pick_stations",
    "require_task_stations",
]


_UNLIMITED = 1_000_000
"""The first automatic limit of a floor without lanes to measure: none, until a cut."""


class TaskDesk:
    """Creates a fleet's tasks at its stations and keeps them in one book.

    Args:
        layout: the floor plan.
        rng: draws drop stations and the pick stations of random tasks.
        clock: the fleet's time, seconds.
        station_range: first auction range of the stations.
        tally: counts the stations' protocol messages.
        history: finished tasks the book keeps in detail.
        on_created: told of every task created, with the time (e.g. a
            :class:`~agv_app.tasks.free_flow.FreeFlowBound`'s ``add``).
        max_open: tasks handed to the stations and not yet done, at most (None: no
            limit; ``"auto"``: a limit that starts at what the floor's lanes carry and
            follows the long waits, ``admission``); the others wait at the desk,
            oldest first.
        one_at_a_time: each station calls one AGV at a time (``Station``).
        wait_for_drop: with ``one_at_a_time``, a station holds a task whose drop
            station an AGV is bound for already (``Station``).
        backlog: open tasks held at most (``BACKLOG_LIMIT``); ``create`` refuses more.
        store: where every change is written through, and what the desk resumes from
            (None: nothing outlives the desk).
        hand_back_after: seconds a vehicle may hold a task without naming it as its
            ``task`` before it counts as handed back (``agv_app.tasks.custody``).

    Raises:
        ValueError: ``max_open`` is set and neither a positive whole number nor
            ``"auto"``; ``backlog`` is below 1; ``hand_back_after`` is not positive.
        StoreError: the store cannot be read.
    """

    def __init__(
        self,
        layout: Layout,
        *,
        rng: random.Random,
        clock: Callable[[], float],
        station_range: float = 30.0,
        tally: MessageTally | None = None,
        history: int = DEFAULT_HISTORY,
        on_created: Callable[[TaskSpec, float], None] | None = None,
        max_open: int | str | None = None,
        one_at_a_time: bool = True,
        wait_for_drop: bool = True,
        backlog: int = BACKLOG_LIMIT,
        store: TaskJournal | None = None,
        hand_back_after: float = DEFAULT_HAND_BACK_AFTER,
    ) -> None:
        check_max_open(max_open)
        if backlog < 1:
            raise ValueError(f"backlog must be at least 1, got {backlog!r}")
        self.backlog = backlog
        self.refused = 0
        """Tasks refused because the desk held ``backlog`` open ones."""
        self.layout = layout
        self.rng = rng
        self.clock = clock
        self.station_range = station_range
        self.tally = tally
        self.book = TaskBook(history=history)
        self.stations: dict[str, Station] = {}
        """The open stations, by station id."""
        self.on_created = on_created
        self.admission: AdaptiveLimit | None = None
        """The limit that follows the floor (``max_open="auto"``; None otherwise)."""
        if max_open == "auto":
            self.admission = AdaptiveLimit(carried_tasks(layout) or _UNLIMITED)
        self.max_open = max_open if isinstance(max_open, int) else None
        self.one_at_a_time = one_at_a_time
        self.wait_for_drop = wait_for_drop
        self._drops = drop_stations(layout)
        self._open: set[str] = set()
        """Tasks handed to their stations and not yet done or cancelled."""
        self._waiting: deque[TaskSpec] = deque()
        """Tasks created while ``max_open`` were open, oldest first."""
        self.custody = CustodyMachine(grace=hand_back_after)
        """Who holds each task handed out, and when one comes back."""
        self.watch = CustodyWatch(self.custody, clock, self._settle)
        """What the base hears of the vehicles that hold tasks (``custody_watch``)."""
        self._adopt: dict[str, list[TaskRecord]] = {}
        """Tasks restored as held by a vehicle, by pick station, until it opens."""
        self.store = store
        if store is not None:
            self._restore(store)
            self.book.on_change = store.task_changed

    def _restore(self, store: TaskJournal) -> None:
        """Take back the open tasks ``store`` kept (see the module docstring)."""
        stored = store.restore_tasks(self.clock, finished=self.book.history)
        self.book.restore(stored.open, stored.finished, created=stored.created)
        held = [r for r in stored.open if r.state in HELD_STATES and r.vehicle is not None]
        held.sort(key=lambda r: r.times.get("assigned", r.times["created"]))
        now = self.clock()
        for record in held:  # in the order they were awarded (``custody``)
            vehicle = record.vehicle
            assert vehicle is not None
            self.custody.hold(record.id, vehicle, now=now, restored=True)
            self._adopt.setdefault(record.task.pick, []).append(record)
            self._open.add(record.id)
        for record in stored.open:
            if record.id not in self._open:
                self._waiting.append(record.task)

    def open_base(self, node: RoleActivator, stations: Iterable[str] | None = None) -> None:
        """Make ``node`` a transport base: it runs the components of ``stations`` (every
        pick station when None).

        The base says what it is (``kind``) and stands at the middle of its stations
        (``position``, where the dashboard draws its sessions from), and never moves: it
        beats as seldom as the fleet lets a node at rest (its sessions' frames go on as
        ever).
        """
        stations = pick_stations(self.layout) if stations is None else list(stations)
        points = [self.layout.point(self.layout.station(sid).point) for sid in stations]
        node.update_node_property("kind", BASE_KIND)
        if points:
            x = sum(p.x for p in points) / len(points)
            y = sum(p.y for p in points) / len(points)
            node.update_node_property("position", (x, y))
        node.set_at_rest(True)
        for sid in stations:
            self.open_station(sid, node)

    def open_station(self, station_id: str, node: RoleActivator) -> Station:
        """Run the task-assignment component of ``station_id`` on ``node``."""
        point = self.layout.point(self.layout.station(station_id).point)
        station = Station(
            node,
            station_id,
            (point.x, point.y),
            range_m=self.station_range,
            on_assigned=self._assigned,
            on_returned=self._returned,
            tally=self.tally,
            one_at_a_time=self.one_at_a_time,
            wait_for_drop=self.wait_for_drop,
        )
        self.stations[station_id] = station
        self.watch.follow(node)
        for record in self._adopt.pop(station_id, []):
            vehicle = self.custody.holder(record.id)
            if vehicle is not None:  # still held
                station.adopt(record.task, vehicle)
        self.watch.arm()
        self._hand_out()  # tasks restored for this station wait no longer for it
        return station

    @property
    def waiting(self) -> int:
        """Tasks created and held at the desk (``max_open`` were open)."""
        return len(self._waiting)

    @property
    def returned(self) -> int:
        """Tasks the stations put back in line because their AGV failed."""
        return sum(s.returned for s in self.stations.values())

    def create(self, station_id: str, drop: str | None = None, *, creator: str = "api") -> str:
        """Create a task at pick station ``station_id``; its station auctions it. With a
        store, the task is on disk when this returns.

        Args:
            station_id: where the load is picked up.
            drop: where it goes (default: a drop station drawn at random).
            creator: who asks for it (kept with the task).

        Returns:
            The new task's id.

        Raises:
            KeyError: the layout has no station ``station_id``.
            ValueError: the station hands out no loads (or is not open on a base).
            BacklogFull: ``backlog`` tasks are open.
            StoreError: the store cannot write: the task is not on disk (a control
                should stop).
        """
        if station_id not in self.layout.stations:
            raise KeyError(f"unknown station {station_id!r}")
        station = self.stations.get(station_id)
        if station is None:
            raise ValueError(f"station {station_id!r} is not a pick station")
        if self.book.open_count >= self.backlog:
            self.refused += 1
            raise BacklogFull(
                f"{self.book.open_count} tasks are open, as many as the task desk holds; "
                "a new one is taken once some are done or cancelled"
            )
        if drop is None:
            choices = [d for d in self._drops if d != station_id]
            drop = choices[self.rng.randrange(len(choices))]
        if self.store is None:
            return self._create(station_id, drop, creator)
        with self.store.transaction():
            return self._create(station_id, drop, creator)

    def _create(self, station_id: str, drop: str, creator: str) -> str:
        now = self.clock()
        task = self.book.create(station_id, drop, now=now, creator=creator)
        if self.on_created is not None:
            self.on_created(task, now)
        self._waiting.append(task)
        self._hand_out()
        return task.id

    def finish(self, task_id: str, *, now: float) -> bool:
        """A vehicle delivered ``task_id``: close it in the book, and hand out the next
        task waiting at the desk. False if the book holds no such open task."""
        if self.store is None:
            return self._finish(task_id, now)
        with self.store.transaction():
            return self._finish(task_id, now)

    def _finish(self, task_id: str, now: float) -> bool:
        finished = self.book.finish(task_id, now=now)
        if finished:
            self.custody.release(task_id)
            if self.admission is not None:
                self.admission.delivered(held_back=bool(self._waiting), now=now)
            self._open.discard(task_id)
            # Done before it left the desk (its book record was assigned directly):
            # it no longer waits.
            self._waiting = deque(t for t in self._waiting if t.id != task_id)
            self._hand_out()
        return finished

    def long_wait(self, now: float) -> None:
        """An AGV that wants to move has waited over a minute (the fleet's stall watch
        says so): the limit that follows the floor is cut (nothing without one)."""
        if self.admission is not None:
            self.admission.long_wait(len(self._open), now)

    @property
    def limit(self) -> int | None:
        """Tasks the desk lets onto the floor at once now (None: no limit)."""
        return self.max_open if self.admission is None else self.admission.limit

    def _hand_out(self) -> None:
        """Give waiting tasks to their stations while fewer than ``limit`` are open
        (oldest first; one whose station is not open yet, restored, keeps its place)."""
        limit = self.limit
        kept: deque[TaskSpec] = deque()
        while self._waiting and (limit is None or len(self._open) < limit):
            task = self._waiting.popleft()
            station = self.stations.get(task.pick)
            if station is None:
                kept.append(task)
                continue
            self._open.add(task.id)
            if self.store is not None:
                self.store.task_queued(task.id, self.clock())
            station.add_task(task)
        if kept:
            kept.extend(self._waiting)
            self._waiting = kept

    def create_random(self) -> str | None:
        """Create a task at a pick station drawn at random; None without stations, or
        when the desk is full (counted in ``refused``)."""
        if not self.stations:
            return None
        ids = sorted(self.stations)
        try:
            return self.create(ids[self.rng.randrange(len(ids))], creator="auto")
        except BacklogFull:
            return None

    def cancel(self, task_id: str) -> None:
        """Withdraw a task that no vehicle holds yet.

        Raises:
            KeyError: no open task has that id.
            ValueError: a vehicle holds it (it was awarded and has not come back).
        """
        record = self.book.get(task_id)
        if record is None or record.state in ("done", "cancelled"):
            raise KeyError(f"no open task {task_id!r}")
        if self.store is None:
            self._cancel(record)
        else:
            with self.store.transaction():
                self._cancel(record)

    def _cancel(self, record: TaskRecord) -> None:
        task_id = record.id
        held = next((t for t in self._waiting if t.id == task_id), None)
        if held is not None:
            self._waiting.remove(held)
            self.book.cancel(task_id, now=self.clock())
            return
        station = self.stations.get(record.task.pick)
        if station is None or not station.cancel(task_id):
            raise ValueError(
                f"task {task_id!r} is {record.state} to {record.vehicle!r}: only a task no "
                "vehicle holds can be cancelled"
            )
        self.book.cancel(task_id, now=self.clock())
        self._open.discard(task_id)
        self._hand_out()

    def _assigned(self, task: TaskSpec, agv: str) -> None:
        now = self.clock()
        self.book.assign(task.id, agv, now=now)
        self.custody.hold(task.id, agv, now=now)
        self.watch.arm()

    def _returned(self, task: TaskSpec, agv: str) -> None:
        self.custody.release(task.id)
        self.book.fail(task.id, now=self.clock())

    def _settle(self, verdicts: list[Verdict]) -> None:
        """Act on what the custody rule concluded."""
        for verdict in verdicts:
            record = self.book.get(verdict.task_id)
            if record is None:
                continue
            station = self.stations.get(record.task.pick)
            if isinstance(verdict, Delivered):
                self.finish(verdict.task_id, now=self.clock())
                if station is not None:
                    station.release(verdict.task_id)
            elif station is not None:
                station.give_back(verdict.task_id)
            else:  # restored for a station not open: back at the desk, first in line
                self._open.discard(verdict.task_id)
                self.book.fail(verdict.task_id, now=self.clock())
                self._waiting.appendleft(record.task)
        self.watch.arm()
