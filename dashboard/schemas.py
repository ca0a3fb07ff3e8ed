"""Request and response bodies of the REST API (pydantic v2).

Every request body is strict (a boolean is never a number, a number never a string),
refuses unknown fields, and is bounded: names are short, numbers finite and in range,
``params`` small. Group definitions have their own models in ``dashboard.definitions``.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from dashboard.definitions import GroupDefinitionIn, Name

__all__ = [
    "MAX_PARAMS",
    "MIN_SPEED",
    "AlarmOut",
    "ErrorOut",
    "EventOut",
    "EventsOut",
    "GroupViewOut",
    "LockOut",
    "MetricsOut",
    "NodeDetailOut",
    "NodeOut",
    "ParticipationOut",
    "SessionDetailOut",
    "SessionOut",
    "SimActionIn",
    "SimOut",
    "SpeedIn",
    "StartSessionIn",
    "StoppedOut",
    "TaskIn",
    "TaskOut",
    "TaskRecordOut",
    "VehicleOut",
]

Polygon = list[list[float]]

MAX_PARAMS = 16
"""Most entries a session's ``params`` may hold."""

MIN_SPEED = 0.01
"""Slowest simulation speed accepted: slower would look frozen while showing as running."""


class _Out(BaseModel):
    model_config = ConfigDict(extra="forbid")


class _In(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class ErrorOut(_Out):
    """Every 4xx answer: what was wrong, in words."""

    detail: str = Field(description="what was wrong with the request")


class NodeOut(_Out):
    """One middleware node in the list."""

    id: str
    properties: dict[str, Any] = Field(description="the node's own current properties")
    initiated: int = Field(description="live sessions this node initiated")
    participating: int = Field(description="sessions this node takes part in")
    messages: int = Field(description="messages sent and received so far")
    bytes: int = Field(description="bytes sent and received so far")


class ParticipationOut(_Out):
    """A participant role live on a node."""

    session_id: str
    initiator: str = Field(description="node id of the session's initiator")
    role: str = Field(description="the participant role's name")


class SessionOut(_Out):
    """One live interaction session."""

    id: str
    node: str = Field(description="the initiator's node")
    role: str = Field(description="the initiator role's name")
    participant_role: str
    members: list[str] = Field(description="current participants, sorted")
    started_at: float = Field(description="simulated time the session started")
    age_s: float = Field(description="seconds since it started")
    definition: Any = Field(
        default=None, description="the group definition as JSON, or None when opaque"
    )
    via_api: bool = Field(description="started through POST /api/sessions (so DELETE may stop it)")


class SessionDetailOut(SessionOut):
    """A session with what its initiator reports (a poll's answers)."""

    params: dict[str, Any] = Field(default_factory=dict, description="parameters it started with")
    detail: Any = Field(
        default=None,
        description="the initiator's own report, e.g. a poll's {node: answer}; None if it has none",
    )


class NodeDetailOut(NodeOut):
    """One node in full: its sessions, participations, counters and view of others."""

    sessions: list[SessionOut]
    participations: list[ParticipationOut]
    stats: dict[str, Any] = Field(description="all the node's counters")
    view: dict[str, dict[str, Any]] = Field(
        description="latest properties this node knows of every other node"
    )


class StartSessionIn(_In):
    """Start an interaction session on a node."""

    node: Name = Field(description="the initiator's node id", examples=["agv-01"])
    role: Name = Field(description="a registered initiator role name", examples=["poll"])
    definition: GroupDefinitionIn = Field(
        description="a declarative group definition (at most 32 levels deep)",
        examples=[{"type": "within", "distance": 20.0}],
    )
    participant_role: Name = Field(examples=["poll-responder"])
    params: dict[Name, Any] = Field(
        default_factory=dict,
        max_length=MAX_PARAMS,
        description="role parameters; poll takes {'property': name}",
        examples=[{"property": "status"}],
    )


class StoppedOut(_Out):
    """The answer to DELETE /api/sessions/{id}."""

    id: str
    stopped: bool = True


class GroupViewOut(_Out):
    """The nodes that satisfy a definition from a node's point of view, now."""

    node: str
    definition: dict[str, Any]
    members: list[str]


class LockOut(_Out):
    """One AGV's locked and requested hull projections."""

    vehicle: str
    status: str
    hull_length: float
    locked: list[Polygon]
    requested: list[Polygon]


class VehicleOut(_Out):
    """One AGV as it stands now."""

    id: str
    x: float = Field(description="metres")
    y: float = Field(description="metres")
    heading: float = Field(description="radians, counter-clockwise from +x")
    length: float = Field(description="hull length along the heading, metres")
    width: float = Field(description="hull width, metres")
    status: str = Field(description="idle, driving, waiting, failed, …")
    task: str | None = Field(description="the task it carries out")
    hull: Polygon
    hull_length: float = Field(description="radius of its collision-avoidance circle")
    locked: list[Polygon]
    requested: list[Polygon]
    speed: float | None = Field(
        default=None, description="m/s as the vehicle reports it (None: not reported)"
    )
    held: bool = Field(default=False, description="it reports holding for an operator's stop")
    in_service: bool = Field(default=True, description="it reports taking tasks")
    battery: float | None = Field(
        default=None, description="state of charge, percent (None: no battery model)"
    )


class TaskIn(_In):
    """Create a transport task at a station."""

    station: Name = Field(examples=["pick-A1-1"])


class TaskOut(_Out):
    """The created task."""

    task_id: str
    station: str


class TaskRecordOut(_Out):
    """A transport order and where it stands."""

    id: str
    creator: str = Field(
        description="who gave it: api (the REST API, the page), auto (automatic tasks), "
        "master (a VDA 5050 master control); empty when unknown"
    )
    source: str = Field(description="pick station id")
    destination: str = Field(description="drop station id")
    state: str = Field(description="waiting, assigned, driving, done, failed or cancelled")
    vehicle: str | None = Field(description="the vehicle that holds or last held it")
    created: float = Field(description="simulated seconds")
    started: float | None = Field(description="when its vehicle last set off with it")
    finished: float | None = Field(description="when it was delivered or cancelled")
    waits: str | None = Field(
        default=None,
        description="why an open order waits for a closed part of the floor "
        "(e.g. 'waits: path P closed'); None when it need not",
    )


class SimOut(_Out):
    """The simulation's clock state."""

    now: float = Field(description="simulated seconds since start")
    paused: bool
    speed: float = Field(description="simulated seconds per wall-clock second")
    stop: Literal["running", "stopping", "stopped"] = Field(
        default="running",
        description="the fleet stop as the vehicles report it: stopped once every one stands",
    )


class SimActionIn(_In):
    """Why the fleet is paused or resumed (the body of pause and resume; ``{}``: no reason)."""

    reason: str = Field(
        default="asked over REST", min_length=1, max_length=200, examples=["aisle blocked"]
    )


class EventOut(_Out):
    """One line of the operator's log."""

    seq: int
    time: float = Field(description="simulated seconds")
    severity: str = Field(description="info, warning or alarm")
    source: str = Field(description="what it is about: a node id, fleet, api")
    text: str


class AlarmOut(_Out):
    """A condition that holds until it clears (an AGV failed, waiting too long)."""

    key: str
    since: float = Field(description="simulated seconds")
    severity: str
    source: str
    text: str


class EventsOut(_Out):
    """The active alarms (most severe, then oldest first) and the latest events."""

    alarms: list[AlarmOut]
    events: list[EventOut] = Field(description="oldest first")
    dropped: int = Field(description="events no longer kept: the history is bounded")


class SpeedIn(_In):
    """Set the simulation speed."""

    factor: float = Field(
        ge=MIN_SPEED,
        le=100,
        allow_inf_nan=False,
        description="simulated seconds per wall-clock second, 0.01 to 100",
    )


class MetricsOut(_Out):
    """Fleet figures and the clock."""

    sim: SimOut
    metrics: dict[str, float | None]
    advance_errors: int = Field(
        description="advances of the fleet that raised so far (logged; the fleet kept going)"
    )
