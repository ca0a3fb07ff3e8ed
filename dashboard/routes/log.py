"""``GET /api/events``: the operator's log and its active alarms (``dashboard.eventlog``)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query

from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.eventlog import DEFAULT_HISTORY, SEVERITIES, Event, Severity
from dashboard.schemas import AlarmOut, EventOut, EventsOut

__all__ = ["router"]

router = APIRouter(prefix="/api/events", tags=["events"])


def event_out(event: Event) -> EventOut:
    """One event as ``EventOut``."""
    return EventOut(
        seq=event.seq,
        time=event.time,
        severity=event.severity,
        source=event.source,
        text=event.text,
    )


@router.get("", response_model=EventsOut, responses=ERROR_RESPONSES)
async def list_events(
    state: State,
    severity: Annotated[Severity | None, Query(description="this severity or worse")] = None,
    limit: Annotated[int, Query(ge=1, le=DEFAULT_HISTORY)] = 200,
) -> EventsOut:
    """Active alarms, then the most recent ``limit`` events (of ``severity`` or worse)."""
    log = state.events
    events = log.events
    if severity is not None:
        least = SEVERITIES.index(severity)
        events = [e for e in events if SEVERITIES.index(e.severity) >= least]
    return EventsOut(
        alarms=[
            AlarmOut(
                key=a.key,
                since=a.event.time,
                severity=a.event.severity,
                source=a.event.source,
                text=a.event.text,
            )
            for a in log.alarms
        ],
        events=[event_out(e) for e in events[-limit:]],
        dropped=log.dropped,
    )
