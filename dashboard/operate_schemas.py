"""Response bodies of the operating endpoints: stopping and resuming vehicles.

``/api/fleet/stop`` and ``/api/fleet/resume`` (``FleetStopOut``), and
``/api/vehicles/{id}/stop``, ``/resume``, ``/out-of-service``, ``/in-service`` and
``/send-home`` (``VehicleMotionOut``). Every figure is
what the vehicles report; ``asked`` alone is what the operator asked.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["FleetStopOut", "VehicleMotionOut"]


class _Out(BaseModel):
    model_config = ConfigDict(extra="forbid")


class VehicleMotionOut(_Out):
    """One vehicle's motion as it reports it, and whether it was told to stand."""

    id: str
    status: str = Field(description="stopping, stopped, driving, waiting, …")
    speed: float | None = Field(description="m/s as reported (None: not reported)")
    held: bool = Field(description="it reports holding for an operator's stop")
    asked: bool = Field(description="it was told to stand (the fleet or it alone)")
    in_service: bool = Field(description="it reports taking tasks")
    in_service_asked: bool = Field(description="it is to take tasks (what was asked)")


class FleetStopOut(_Out):
    """The fleet stop as the vehicles report it."""

    state: Literal["running", "stopping", "stopped"] = Field(
        description="stopped only once every vehicle reports standing"
    )
    asked: bool = Field(description="a fleet stop is in force (asked, not done)")
    automatic_tasks: bool = Field(
        description="the fleet creates its automatic tasks (never while a stop is in force)"
    )
    moving: list[str] = Field(description="vehicles that do not report standing yet")
    vehicles: list[VehicleMotionOut]
