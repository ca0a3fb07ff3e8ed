"""``/api/locks`` and ``/api/metrics``: the AGV fleet itself (tasks: ``routes/tasks``)."""

from __future__ import annotations

import math
from typing import Any

from fastapi import APIRouter, Request

from dashboard.capture import capture
from dashboard.deps import State
from dashboard.schemas import LockOut, MetricsOut

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


@router.get("/metrics", response_model=MetricsOut)
async def get_metrics(state: State, request: Request) -> MetricsOut:
    """Fleet figures (tasks, messages, safety), the clock, and failed advances."""
    metrics = {
        str(k): (float(v) if math.isfinite(float(v)) else None) for k, v in state.metrics().items()
    }
    driver = request.app.state.driver
    return MetricsOut(sim=state.sim(), metrics=metrics, advance_errors=driver.advance_errors)
