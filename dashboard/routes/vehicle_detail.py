"""``GET /api/vehicles/{id}/detail``: one AGV in full, for the vehicle panel (read only)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Path

from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.panel_schemas import VehicleDetailOut
from dashboard.vehicle_detail import vehicle_detail

__all__ = ["router"]

router = APIRouter(prefix="/api/vehicles", tags=["vehicles"])

VehicleId = Annotated[str, Path(min_length=1, max_length=128)]


@router.get("/{vehicle_id}/detail", response_model=VehicleDetailOut, responses=ERROR_RESPONSES)
async def get_vehicle_detail(vehicle_id: VehicleId, state: State) -> dict[str, Any]:
    """One AGV with the rest of its route, its wait, the sessions it initiated and takes
    part in, and its node's traffic."""
    source = state.source
    vehicle = next((v for v in source.vehicles() if v.id == vehicle_id), None)
    if vehicle is None:
        raise HTTPException(404, f"unknown vehicle {shown(vehicle_id)}")
    return vehicle_detail(
        source,
        vehicle,
        node=source.nodes().get(vehicle_id),
        sessions=state.sessions(),
        waiting_since=state.watch.waiting_since(vehicle_id),
        now=float(source.now),
    )
