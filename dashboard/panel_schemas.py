"""Response bodies of the vehicle panel's and the groups panel's endpoints.

``GET /api/vehicles/{id}/detail`` (``VehicleDetailOut``) and ``GET /api/membership``,
``GET /api/membership/{session id}`` (``MembershipSummaryOut``, ``MembershipOut``).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from dashboard.schemas import ParticipationOut, VehicleOut

__all__ = [
    "InitiatedOut",
    "MemberChangeOut",
    "MembershipOut",
    "MembershipSummaryOut",
    "TrafficOut",
    "VehicleDetailOut",
    "VehicleParticipationOut",
    "WaitOut",
]

Point = list[float]


class _Out(BaseModel):
    model_config = ConfigDict(extra="forbid")


class WaitOut(_Out):
    """Whether an AGV waits, and since when."""

    waiting: bool = Field(description="its status is 'waiting'")
    since: float | None = Field(description="simulated time it began to wait, when known")
    seconds: float | None = Field(description="how long it has waited so far")


class InitiatedOut(_Out):
    """A live session the AGV initiated."""

    id: str
    node: str
    role: str
    participant_role: str
    members: list[str]
    started_at: float
    age_s: float
    definition: Any = Field(description="the session's group definition as JSON")
    via_api: bool


class VehicleParticipationOut(ParticipationOut):
    """A session the AGV takes part in, with what the dashboard knows of it."""

    initiator_role: str | None = Field(description="the initiator's role, when still live")
    members: int | None = Field(description="how many members the session has now")
    age_s: float | None = Field(description="the session's age in seconds")


class TrafficOut(_Out):
    """What the AGV's node put on the wire and took off it."""

    frames_sent: int
    bytes_sent: int
    frames_received: int
    bytes_received: int
    sent: dict[str, list[int]] = Field(description="by kind: [frames, bytes]")
    received: dict[str, list[int]] = Field(description="by kind: [frames, bytes]")


class VehicleDetailOut(VehicleOut):
    """One AGV in full: the vehicle record plus route, wait, sessions and traffic."""

    route: list[Point] = Field(description="the rest of its route, [[x, y], ...]; [] at rest")
    route_length: float = Field(description="metres left on the route")
    destination: Point | None = Field(description="where the route ends")
    wait: WaitOut
    initiated: list[InitiatedOut] = Field(description="live sessions it initiated")
    participating: list[VehicleParticipationOut] = Field(description="sessions it takes part in")
    traffic: TrafficOut | None = Field(description="its node's traffic; null without a node")


class MemberChangeOut(_Out):
    """A member joining or leaving a session."""

    time: float = Field(description="simulated seconds (when the dashboard saw it)")
    node: str
    change: Literal["joined", "left"]


class MembershipSummaryOut(_Out):
    """A session whose membership the dashboard follows."""

    id: str
    node: str = Field(description="the initiator")
    role: str
    participant_role: str
    started_at: float
    ended_at: float | None = Field(description="when it was seen to end; null while live")
    members: list[str] = Field(description="its members now (none once ended)")
    joins: int
    leaves: int


class MembershipOut(MembershipSummaryOut):
    """A session's members now and the history of joins and leaves, oldest first."""

    definition: Any = Field(description="the session's group definition as JSON")
    changes: list[MemberChangeOut]
    dropped: int = Field(description="older changes no longer kept")
