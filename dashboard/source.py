"""What the dashboard needs from a running fleet: the ``FleetSource`` protocol.

The fleet implements these members directly (structural typing: it never imports the
dashboard, the import arrows point the other way). Every record below is a read-only
``Protocol``, so a frozen dataclass with the same field names satisfies it.

Threading: the dashboard drives the fleet from one asyncio task (``advance``) and calls
everything else from request handlers on the same event loop, so nothing here is called
concurrently and an implementation needs no locks. No member may block.

Optional hooks: a fleet that needs the event loop to start (one whose AGVs run as
separate processes on the WebSocket mesh) may define ``async def start()`` and
``async def stop()``; the app awaits ``start()`` before it first advances the fleet and
``stop()`` when it shuts down.

Geometry travels as plain numbers: a point is ``(x, y)`` in metres, world y pointing up;
a polygon is a sequence of ``(x, y)`` vertices, not closed (first vertex not repeated).
Give projections as tuples of tuples where you can: the dashboard then converts each
distinct polygon once instead of 20 times a second.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

from agv_app.layout import Layout
from objectplaces import (
    Initiator,
    NodeStats,
    Participant,
    ParticipationInfo,
    Session,
    SessionInfo,
)
from objectplaces.core.groups import DefinitionLike

__all__ = [
    "XY",
    "FleetSource",
    "InitiatorFactory",
    "NodeHandle",
    "Polygon",
    "TaskBookSource",
    "TaskRecordView",
    "TaskSpecView",
    "UnknownStationError",
    "VehicleView",
]

XY = Sequence[float]
"""A point ``(x, y)`` in metres."""

Polygon = Sequence[XY]
"""A simple polygon as its vertices ``[(x, y), ...]``, not closed."""

InitiatorFactory = Callable[[Mapping[str, Any]], Initiator]
"""Builds a fresh initiator role from request parameters.

The mapping is the ``params`` object of ``POST /api/sessions`` (empty when absent). A
factory raises ``ValueError`` with a clear message when a parameter is missing or bad;
the dashboard answers 422 with that message.
"""


class NodeHandle(Protocol):
    """A middleware node as the dashboard reads and drives it.

    An ``objectplaces.RoleActivator`` is one. A fleet whose nodes run in other
    processes may give a stand-in that reads what the node publishes; its members that
    would act on the node (``start_interaction``, ``stop_interaction``, ``view_group``)
    then raise ``objectplaces.LocalProtocolError``, which the API answers with 422.
    """

    @property
    def node_id(self) -> str:
        """The node's id."""
        ...

    @property
    def properties(self) -> Mapping[str, Any]:
        """The node's own current properties."""
        ...

    def view(self) -> Mapping[str, Mapping[str, Any]]:
        """The latest properties the node knows of the others, by node id."""
        ...

    def sessions(self) -> list[SessionInfo]:
        """Live sessions the node initiated."""
        ...

    def participations(self) -> list[ParticipationInfo]:
        """Participant roles active on the node."""
        ...

    def stats(self) -> NodeStats:
        """The node's traffic and drop counters."""
        ...

    def set_participant_factory(self, name: str, factory: Callable[[], Participant] | None) -> None:
        """Register a participant role on the node (None removes it)."""
        ...

    def start_interaction(
        self, initiator: Initiator, definition: DefinitionLike, participant_role: str
    ) -> Session:
        """Start a session on the node."""
        ...

    def stop_interaction(self, session: Session | str) -> None:
        """Stop a session the node started."""
        ...

    def view_group(self, definition: DefinitionLike) -> frozenset[str]:
        """The nodes that satisfy ``definition`` now, from the node's view."""
        ...


class UnknownStationError(LookupError):
    """Raised by ``FleetSource.create_task`` for a station id the layout does not have.

    The fleet may raise any ``LookupError`` (``KeyError`` included); the dashboard
    answers 404 for all of them.
    """


class VehicleView(Protocol):
    """One AGV as it stands now."""

    @property
    def id(self) -> str:
        """The AGV's id, equal to its middleware node id."""
        ...

    @property
    def x(self) -> float:
        """Position x in metres (the point the hull length is measured from)."""
        ...

    @property
    def y(self) -> float:
        """Position y in metres."""
        ...

    @property
    def heading_rad(self) -> float:
        """Heading, counter-clockwise from +x."""
        ...

    @property
    def length_m(self) -> float:
        """Hull length along the heading."""
        ...

    @property
    def width_m(self) -> float:
        """Hull width across the heading."""
        ...

    @property
    def status(self) -> str:
        """A short state such as ``"idle"``, ``"driving"``, ``"waiting"``,
        ``"failed"`` (free text; the page colours the known ones)."""
        ...

    @property
    def task_id(self) -> str | None:
        """The task it is carrying out, or None."""
        ...

    @property
    def hull(self) -> Polygon:
        """The hull rectangle on the floor at the current pose."""
        ...

    @property
    def hull_length(self) -> float:
        """Distance from the position to the furthest point of locked and requested
        projections: the radius of the collision-avoidance circle."""
        ...

    @property
    def locked(self) -> Sequence[Polygon]:
        """Hull projections this AGV holds a lock on."""
        ...

    @property
    def requested(self) -> Sequence[Polygon]:
        """Hull projections this AGV has asked for and not yet locked."""
        ...


@runtime_checkable
class FleetSource(Protocol):
    """A running fleet as the dashboard sees it.

    Sessions, memberships and per-node message counters are read from the nodes
    themselves (``nodes()``), so the fleet does not report them separately; locks are
    read from ``vehicles()``.
    """

    def layout_view(self) -> Layout:
        """The floor plan the fleet drives on (constant for the whole run)."""
        ...

    def vehicles(self) -> Sequence[VehicleView]:
        """Every AGV, in a stable order (by id is best)."""
        ...

    def nodes(self) -> Mapping[str, NodeHandle]:
        """The middleware node handles the dashboard
        may inspect and start sessions on, by node id: every AGV, every station, and
        the dashboard's own observer node (see ``observer_id``). A node in another
        process may be a read-only stand-in (``NodeHandle``)."""
        ...

    @property
    def observer_id(self) -> str:
        """Id of the observer node in ``nodes()`` that belongs to the dashboard: a node
        with no position of its own, used for ``view_group`` when the caller names none."""
        ...

    def initiator_roles(self) -> Mapping[str, InitiatorFactory]:
        """Initiator roles the fleet lets a user start over HTTP, by name (e.g. the
        AGV roles). The dashboard adds its own ``poll`` role to these."""
        ...

    def metrics(self) -> Mapping[str, float]:
        """Fleet figures so far. The page charts ``tasks_per_hour`` and the rate of
        ``messages``; it lists every key. Expected keys (others are welcome):
        ``tasks_created``, ``tasks_completed``, ``tasks_per_hour``, ``messages``,
        ``bytes``, ``collisions``, ``lock_overlaps``, ``deadlocks``."""
        ...

    def create_task(self, station_id: str) -> str:
        """Create a transport task at a station; its task-assignment session starts.

        Args:
            station_id: a station id from ``layout_view()``.

        Returns:
            The new task's id.

        Raises:
            LookupError: no station has that id (``UnknownStationError`` or ``KeyError``).
            ValueError: the station cannot take a task (e.g. a charging station).
            agv_app.tasks.desk.BacklogFull: the fleet holds as many open tasks as it
                takes.
        """
        ...

    def pause(self) -> None:
        """Stop simulated time: ``advance`` is not called while paused."""
        ...

    def resume(self) -> None:
        """Let simulated time run again."""
        ...

    def set_speed(self, factor: float) -> None:
        """Set how many simulated seconds pass per wall-clock second.

        Raises:
            ValueError: ``factor`` is not positive (the dashboard checks its own range
                first, so this is a last line of defence).
        """
        ...

    @property
    def paused(self) -> bool:
        """True between ``pause()`` and ``resume()``."""
        ...

    @property
    def speed(self) -> float:
        """The factor last given to ``set_speed`` (1.0 to start with)."""
        ...

    @property
    def now(self) -> float:
        """Simulated time in seconds since the fleet started."""
        ...

    def advance(self, seconds: float) -> None:
        """Advance the simulation by ``seconds`` of simulated time.

        The dashboard calls it about 50 times a wall-clock second with
        ``wall_elapsed * speed`` (capped, so a stalled loop does not cause a jump),
        and never while paused. The fleet steps its own fixed increments inside.
        """
        ...


class TaskSpecView(Protocol):
    """What a transport task carries: from where to where."""

    @property
    def id(self) -> str:
        """The task's id."""
        ...

    @property
    def pick(self) -> str:
        """Station id where the load is picked up."""
        ...

    @property
    def drop(self) -> str:
        """Station id where the load is dropped."""
        ...


class TaskRecordView(Protocol):
    """One transport task as the fleet's task book holds it."""

    @property
    def task(self) -> TaskSpecView:
        """What the task carries."""
        ...

    @property
    def state(self) -> str:
        """``created``, ``assigned``, ``driving``, ``done``, ``failed`` or ``cancelled``."""
        ...

    @property
    def vehicle(self) -> str | None:
        """The vehicle that holds or last held it."""
        ...

    @property
    def creator(self) -> str:
        """Who gave it: ``api``, ``auto`` or ``master`` (a VDA 5050 master control)."""
        ...

    @property
    def times(self) -> Mapping[Any, float]:
        """When it last entered each state it has passed (keyed by state name), seconds."""
        ...


@runtime_checkable
class TaskBookSource(Protocol):
    """A fleet that keeps a task book; the dashboard then lists and cancels its tasks.

    Optional: for a ``FleetSource`` without these members ``GET /api/tasks`` is empty.
    """

    def task_records(self) -> Sequence[TaskRecordView]:
        """Every task held in detail (bounded history of finished ones, then open ones)."""
        ...

    def task_record(self, task_id: str) -> TaskRecordView | None:
        """One task, or None if the book holds it no more (or never did)."""
        ...

    def cancel_task(self, task_id: str) -> None:
        """Withdraw a task no vehicle holds yet.

        Raises:
            KeyError: no open task has that id.
            ValueError: a vehicle holds it.
        """
        ...
