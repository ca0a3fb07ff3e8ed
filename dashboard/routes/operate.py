"""Operating the vehicles: stop and resume the fleet, or one vehicle; out of service;
send home.

``POST /api/fleet/stop`` and ``/api/fleet/resume``, ``GET /api/fleet/stop``,
``POST /api/vehicles/{id}/stop`` and ``/resume``, ``POST
/api/vehicles/{id}/out-of-service`` and ``/in-service`` (it hands back a task it has
not loaded, delivers a loaded one, parks at home and takes no more, until brought
back), and ``POST /api/vehicles/{id}/send-home`` (it hands back a task it has not
loaded and drives home, taking tasks again once there; :mod:`agv_app.vehicle.service`).
A stopped vehicle brakes to a standstill within its braking distance and stands with
its locks; resumed, its order goes on (:mod:`agv_app.fleet.holding`). While the fleet
is stopped it creates no automatic tasks. The answers show what the vehicles report, so a
stop answers ``stopping`` until every vehicle stands. Only the operator may call the
changes (``dashboard.guard``); each is logged in the event log with who asked and why.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Path, Request

from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.operate_schemas import FleetStopOut, VehicleMotionOut
from dashboard.schemas import SimActionIn
from dashboard.source import VehicleView
from dashboard.state import DashboardState
from dashboard.stopping import (
    StoppableFleet,
    in_service_of,
    motion_of,
    stands,
    stop_state,
    who_asked,
)

__all__ = ["fleet_stop_out", "router"]

router = APIRouter(prefix="/api", tags=["operate"], responses=ERROR_RESPONSES)

VehicleId = Annotated[str, Path(min_length=1, max_length=128)]


def _fleet(state: DashboardState) -> StoppableFleet:
    source = state.source
    if not isinstance(source, StoppableFleet):
        raise HTTPException(409, "this fleet cannot stop its vehicles")
    return source


def _motion(vehicle: VehicleView, fleet: StoppableFleet) -> dict[str, Any]:
    speed, held = motion_of(vehicle)
    return {
        "id": vehicle.id,
        "status": str(vehicle.status),
        "speed": None if math.isnan(speed) else speed,
        "held": held,
        "asked": fleet.stop_asked(vehicle.id),
        "in_service": in_service_of(vehicle),
        "in_service_asked": fleet.service_asked(vehicle.id),
    }


def fleet_stop_out(fleet: StoppableFleet, vehicles: Sequence[VehicleView]) -> FleetStopOut:
    """The fleet stop as the vehicles report it."""
    ordered = sorted(vehicles, key=lambda v: v.id)
    rows = [_motion(v, fleet) for v in ordered]
    return FleetStopOut(
        state=stop_state(fleet.fleet_stopped, vehicles),
        asked=fleet.fleet_stopped,
        automatic_tasks=fleet.automatic_tasks,
        moving=[v.id for v in ordered if not stands(v)],
        vehicles=[VehicleMotionOut(**r) for r in rows],
    )


def _vehicle(state: DashboardState, vehicle_id: str) -> VehicleView:
    vehicles = {v.id: v for v in state.source.vehicles()}
    vehicle = vehicles.get(vehicle_id)
    if vehicle is None:
        known = ", ".join(sorted(vehicles)[:8]) + (", ..." if len(vehicles) > 8 else "")
        raise HTTPException(404, f"unknown vehicle {shown(vehicle_id)} (known: {known})")
    return vehicle


def _log(state: DashboardState, source: str, text: str, *, warning: bool) -> None:
    state.events.record(float(state.source.now), "warning" if warning else "info", source, text)
    state.publish()


@router.get("/fleet/stop", response_model=FleetStopOut)
async def get_fleet_stop(state: State) -> FleetStopOut:
    """Whether a fleet stop is in force, and every vehicle's motion as it reports it."""
    fleet = _fleet(state)
    return fleet_stop_out(fleet, state.source.vehicles())


@router.post("/fleet/stop", response_model=FleetStopOut)
async def stop_fleet(body: SimActionIn, state: State, request: Request) -> FleetStopOut:
    """Stop every vehicle: each brakes to a standstill and stands, locks kept, and the
    fleet creates no automatic tasks until resumed. The answer is ``stopping`` until
    every vehicle reports standing (poll ``GET``)."""
    fleet = _fleet(state)
    fleet.stop_vehicles(None)
    _log(state, "fleet", f"fleet stop asked by {who_asked(request)}: {body.reason}", warning=True)
    return fleet_stop_out(fleet, state.source.vehicles())


@router.post("/fleet/resume", response_model=FleetStopOut)
async def resume_fleet(body: SimActionIn, state: State, request: Request) -> FleetStopOut:
    """Let the vehicles drive on (one stopped on its own stays stopped) and create
    automatic tasks again."""
    fleet = _fleet(state)
    fleet.resume_vehicles(None)
    _log(
        state, "fleet", f"fleet resume asked by {who_asked(request)}: {body.reason}", warning=False
    )
    return fleet_stop_out(fleet, state.source.vehicles())


def _act(
    state: DashboardState,
    vehicle_id: str,
    request: Request,
    body: SimActionIn,
    act: Callable[[StoppableFleet], None],
    what: str,
    *,
    warning: bool,
) -> dict[str, Any]:
    """Do ``act`` for one known vehicle, log ``what`` with who asked and why, and answer
    with the vehicle's motion as it reports it now."""
    fleet = _fleet(state)
    _vehicle(state, vehicle_id)
    act(fleet)
    text = f"{vehicle_id} {what} asked by {who_asked(request)}: {body.reason}"
    _log(state, vehicle_id, text, warning=warning)
    return _motion(_vehicle(state, vehicle_id), fleet)


@router.post("/vehicles/{vehicle_id}/stop", response_model=VehicleMotionOut)
async def stop_vehicle(
    vehicle_id: VehicleId, body: SimActionIn, state: State, request: Request
) -> dict[str, Any]:
    """Stop one vehicle; the answer is its motion as it reports it now."""

    def stop(fleet: StoppableFleet) -> None:
        fleet.stop_vehicles([vehicle_id])

    return _act(state, vehicle_id, request, body, stop, "stop", warning=True)


@router.post("/vehicles/{vehicle_id}/resume", response_model=VehicleMotionOut)
async def resume_vehicle(
    vehicle_id: VehicleId, body: SimActionIn, state: State, request: Request
) -> dict[str, Any]:
    """Let one vehicle drive on; 409 while the whole fleet is stopped."""

    def resume(fleet: StoppableFleet) -> None:
        try:
            fleet.resume_vehicles([vehicle_id])
        except ValueError as exc:
            raise HTTPException(409, str(exc)) from exc

    return _act(state, vehicle_id, request, body, resume, "resume", warning=False)


@router.post("/vehicles/{vehicle_id}/out-of-service", response_model=VehicleMotionOut)
async def take_out_of_service(
    vehicle_id: VehicleId, body: SimActionIn, state: State, request: Request
) -> dict[str, Any]:
    """Take one vehicle out of service: it hands back a task it has not loaded (another
    vehicle does it), delivers a loaded one, drives home and parks there, taking no more
    (its status ``out-of-service`` once parked)."""

    def retire(fleet: StoppableFleet) -> None:
        fleet.set_service([vehicle_id], in_service=False)

    return _act(state, vehicle_id, request, body, retire, "out of service,", warning=True)


@router.post("/vehicles/{vehicle_id}/in-service", response_model=VehicleMotionOut)
async def bring_into_service(
    vehicle_id: VehicleId, body: SimActionIn, state: State, request: Request
) -> dict[str, Any]:
    """Bring one vehicle back into service: it takes tasks again."""

    def restore(fleet: StoppableFleet) -> None:
        fleet.set_service([vehicle_id], in_service=True)

    return _act(state, vehicle_id, request, body, restore, "back in service,", warning=False)


@router.post("/vehicles/{vehicle_id}/send-home", response_model=VehicleMotionOut)
async def send_home(
    vehicle_id: VehicleId, body: SimActionIn, state: State, request: Request
) -> dict[str, Any]:
    """Send one vehicle home: it hands back a task it has not loaded (another vehicle
    does it) and drives to its home, taking tasks again once there. 409 while it is
    loaded, out of service or failed."""

    def home(fleet: StoppableFleet) -> None:
        try:
            fleet.send_home(vehicle_id)
        except ValueError as exc:
            raise HTTPException(409, str(exc)) from exc

    return _act(state, vehicle_id, request, body, home, "sent home,", warning=False)
