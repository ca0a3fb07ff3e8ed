"""``/api/locks``, ``/api/tasks`` and ``/api/metrics``: the AGV fleet itself."""

from __future__ import annotations

import math
from typing import Any

from fastapi import APIRouter, Depends, HTTPException, Request

from dashboard.capture import capture
from dashboard.deps import State, require_token
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.schemas import LockOut, MetricsOut, TaskIn, TaskOut

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["fleet"])


@router.get("/locks", response_model=list[LockOut])
async def list_locks(state: State) -> list[dict[str, Any]]:
    """Every AGV's locked and requested hull projections."""
    vehicles = capture(state.source, sessions={}, nodes={}).vehicles
    return [
        {
            "vehicle": vid,
            "status": rec["status"],
            "hull_length": rec["hull_length"],
            "locked": rec["locked"],
            "requested": rec["requested"],
        }
        for vid, rec in sorted(vehicles.items())
    ]


@router.post(
    "/tasks",
    status_code=201,
    response_model=TaskOut,
    responses=ERROR_RESPONSES,
    dependencies=[Depends(require_token)],
)
async def create_task(body: TaskIn, state: State) -> TaskOut:
    """Create a transport task at a station (starts its task-assignment session)."""
    try:
        task_id = state.source.create_task(body.station)
    except LookupError as exc:
        known = ", ".join(s["id"] for s in state.layout["stations"])
        raise HTTPException(404, f"unknown station {shown(body.station)} (known: {known})") from exc
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from exc
    return TaskOut(task_id=str(task_id), station=body.station)


@router.get("/metrics", response_model=MetricsOut)
async def get_metrics(state: State, request: Request) -> MetricsOut:
    """Fleet figures (tasks, messages, safety), the clock, and failed advances."""
    metrics = {
        str(k): (float(v) if math.isfinite(float(v)) else None)
        for k, v in state.source.metrics().items()
    }
    driver = request.app.state.driver
    return MetricsOut(sim=state.sim(), metrics=metrics, advance_errors=driver.advance_errors)
