"""Stopping vehicles from the dashboard, and the fleet's stop as the vehicles report it.

A fleet that can stop its vehicles satisfies :class:`StoppableFleet` (both of the AGV
app's fleets do: :mod:`agv_app.fleet.holding`). What the page and the REST API show is
what the vehicles report, never what was asked: :func:`stop_state` calls the fleet
``stopped`` only once every vehicle reports that it holds and stands (a failed one
stands for good), ``stopping`` before that.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from typing import Literal, Protocol, runtime_checkable

from starlette.requests import Request

from dashboard.source import VehicleView

__all__ = [
    "StopState",
    "StoppableFleet",
    "fleet_stop_asked",
    "in_service_of",
    "motion_of",
    "stands",
    "stop_state",
    "who_asked",
]

StopState = Literal["running", "stopping", "stopped"]
"""``running``: no fleet stop asked; ``stopping``: asked, some vehicle still moves or
has not heard it; ``stopped``: every vehicle reports standing."""


@runtime_checkable
class StoppableFleet(Protocol):
    """A fleet whose vehicles the operator can stop and resume."""

    def stop_vehicles(self, vehicle_ids: Collection[str] | None = None) -> None:
        """Stop ``vehicle_ids`` (None: the fleet); KeyError names an unknown one."""
        ...

    def resume_vehicles(self, vehicle_ids: Collection[str] | None = None) -> None:
        """Resume ``vehicle_ids`` (None: the fleet); ValueError while the fleet is
        stopped and single vehicles are named."""
        ...

    @property
    def fleet_stopped(self) -> bool:
        """Whether a fleet stop was asked (not whether it is done)."""
        ...

    def stop_asked(self, vehicle_id: str) -> bool:
        """Whether ``vehicle_id`` was told to stand (the fleet's stop or its own)."""
        ...

    def set_service(self, vehicle_ids: Collection[str], *, in_service: bool) -> None:
        """Take ``vehicle_ids`` out of service or bring them back; KeyError names an
        unknown one."""
        ...

    def service_asked(self, vehicle_id: str) -> bool:
        """Whether ``vehicle_id`` is to be in service (what was asked)."""
        ...

    def send_home(self, vehicle_id: str) -> None:
        """Send ``vehicle_id`` home (it hands back a task not loaded); KeyError names an
        unknown one, ValueError says why it cannot go now."""
        ...

    @property
    def automatic_tasks(self) -> bool:
        """Whether the fleet creates its automatic tasks now (not while stopped)."""
        ...


def fleet_stop_asked(source: object) -> bool:
    """Whether ``source`` is a fleet that was told to stop (False for any other)."""
    return isinstance(source, StoppableFleet) and bool(source.fleet_stopped)


def motion_of(vehicle: VehicleView) -> tuple[float, bool]:
    """The vehicle's reported speed (m/s) and whether it reports holding; a view that
    reports neither counts as moving and not held (it is never shown stopped)."""
    speed = getattr(vehicle, "speed_m_s", None)
    held = getattr(vehicle, "held", None)
    if not isinstance(speed, int | float) or isinstance(speed, bool):
        return (float("nan"), False)
    return (float(speed), held is True)


def in_service_of(vehicle: VehicleView) -> bool:
    """Whether the vehicle reports taking tasks (a view that does not say: True)."""
    return getattr(vehicle, "in_service", True) is not False


def stands(vehicle: VehicleView) -> bool:
    """Whether the vehicle reports standing for a stop: speed 0, and holding (or failed)."""
    speed, held = motion_of(vehicle)
    return speed == 0.0 and (held or vehicle.status == "failed")


def stop_state(fleet_stopped: bool, vehicles: Sequence[VehicleView]) -> StopState:
    """The fleet's stop as its vehicles report it."""
    if not fleet_stopped:
        return "running"
    return "stopped" if all(stands(v) for v in vehicles) else "stopping"


def who_asked(request: Request) -> str:
    """Who made a change, for the event log: the role proved and the client's address."""
    role = getattr(request.state, "role", None) or "unknown role"
    client = request.client.host if request.client is not None else "unknown address"
    return f"{role} at {client}"
