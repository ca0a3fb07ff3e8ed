"""``GET /api/vehicles`` and ``GET /api/vehicles/{id}``: the AGVs as they stand, read only."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Path

from dashboard.capture import vehicle_json
from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.schemas import VehicleOut

__all__ = ["router"]

router = APIRouter(prefix="/api/vehicles", tags=["vehicles"])

VehicleId = Annotated[str, Path(min_length=1, max_length=128)]


@router.get("", response_model=list[VehicleOut])
async def list_vehicles(state: State) -> list[dict[str, Any]]:
    """Every AGV: pose, status, task, hull and lock state, sorted by id."""
    vehicles = sorted(state.source.vehicles(), key=lambda v: v.id)
    return [{"id": v.id, **vehicle_json(v)} for v in vehicles]


@router.get("/{vehicle_id}", response_model=VehicleOut, responses=ERROR_RESPONSES)
async def get_vehicle(vehicle_id: VehicleId, state: State) -> dict[str, Any]:
    """One AGV."""
    vehicles = {v.id: v for v in state.source.vehicles()}
    vehicle = vehicles.get(vehicle_id)
    if vehicle is None:
        known = ", ".join(sorted(vehicles)[:8]) + (", ..." if len(vehicles) > 8 else "")
        raise HTTPException(404, f"unknown vehicle {shown(vehicle_id)} (known: {known})")
    return {"id": vehicle.id, **vehicle_json(vehicle)}
