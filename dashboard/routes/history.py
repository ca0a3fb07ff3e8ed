"""``GET /api/metrics/history``: the fleet's figures over time, as JSON or CSV.

The samples come from the app's :class:`~dashboard.history.MetricsHistory` (one at most
every few simulated seconds, the newest few hundred kept). The JSON form also carries the
histogram of how long transport orders waited for a vehicle; the CSV form is the time
series alone, one row per sample, for a spreadsheet.
"""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Query, Request
from fastapi.responses import PlainTextResponse
from pydantic import BaseModel, ConfigDict, Field

from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.history import WAIT_EDGES_S, MetricsHistory, order_waits, wait_histogram

__all__ = ["HistoryOut", "router"]

router = APIRouter(prefix="/api/metrics", tags=["fleet"])

MAX_LIMIT = 10_000
"""Most samples one request may ask for (more than any history keeps)."""


class _Out(BaseModel):
    model_config = ConfigDict(extra="forbid")


class SampleOut(_Out):
    """The fleet at one instant."""

    time: float = Field(description="simulated seconds")
    metrics: dict[str, float] = Field(description="the fleet's figures (finite ones)")
    sent: dict[str, int] = Field(description="frames sent so far by kind, over every node")


class WaitTimesOut(_Out):
    """How long transport orders waited for a vehicle (created to assigned)."""

    edges_s: list[float] = Field(description="lower edge of each bin; the last has no upper")
    counts: list[int] = Field(description="orders per bin")
    orders: int = Field(description="orders counted (those still waiting are not)")


class HistoryOut(_Out):
    """The metrics history."""

    every_s: float = Field(description="least simulated seconds between two samples")
    capacity: int = Field(description="most samples kept")
    dropped: int = Field(description="older samples no longer kept")
    samples: list[SampleOut]
    wait_times: WaitTimesOut


def _history(request: Request) -> MetricsHistory:
    history = request.app.state.history
    assert isinstance(history, MetricsHistory)
    return history


@router.get(
    "/history",
    response_model=HistoryOut,
    responses={
        **ERROR_RESPONSES,
        200: {"content": {"text/csv": {}}, "description": "JSON, or CSV with format=csv"},
    },
)
async def get_history(
    state: State,
    request: Request,
    format: Annotated[
        Literal["json", "csv"], Query(description="json (default) or csv (a download)")
    ] = "json",
    limit: Annotated[int | None, Query(ge=1, le=MAX_LIMIT, description="newest samples")] = None,
    download: Annotated[bool, Query(description="answer as a file to save")] = False,
) -> HistoryOut | PlainTextResponse:
    """The samples, oldest first (the newest ``limit``), and the orders' wait times."""
    history = _history(request)
    if format == "csv":
        return PlainTextResponse(
            history.as_csv(limit),
            media_type="text/csv",
            headers={"Content-Disposition": 'attachment; filename="metrics-history.csv"'},
        )
    waits = order_waits(state.source)
    out = HistoryOut(
        every_s=history.every_s,
        capacity=history.capacity,
        dropped=history.dropped,
        samples=[SampleOut(**s.as_json()) for s in history.samples(limit)],
        wait_times=WaitTimesOut(
            edges_s=list(WAIT_EDGES_S), counts=wait_histogram(waits), orders=len(waits)
        ),
    )
    if download:
        return PlainTextResponse(
            out.model_dump_json(),
            media_type="application/json",
            headers={"Content-Disposition": 'attachment; filename="metrics-history.json"'},
        )
    return out
