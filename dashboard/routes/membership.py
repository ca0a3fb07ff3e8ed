"""``/api/membership``: who joined and left each session, and when (read only).

The history is kept by ``dashboard.membership`` from the sessions the driver reads for
the feed; ended sessions stay listed for a while (bounded).
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Path, Query

from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.membership import SessionMembership
from dashboard.panel_schemas import MembershipOut, MembershipSummaryOut
from objectplaces.json_form import json_value

__all__ = ["MAX_LISTED", "router"]

router = APIRouter(prefix="/api/membership", tags=["sessions"])

MAX_LISTED = 500
"""Most sessions one ``GET /api/membership`` answers."""

SessionId = Annotated[
    str, Path(min_length=1, max_length=256, description="the session's id; write '#' as '%23'")
]


def _summary(entry: SessionMembership) -> dict[str, Any]:
    rec = entry.record
    return {
        "id": rec.session_id,
        "node": rec.node,
        "role": rec.role,
        "participant_role": rec.participant_role,
        "started_at": rec.started_at,
        "ended_at": entry.ended_at,
        "members": sorted(entry.members),
        "joins": entry.joins,
        "leaves": entry.leaves,
    }


@router.get("", response_model=list[MembershipSummaryOut], responses=ERROR_RESPONSES)
async def list_memberships(
    state: State, limit: Annotated[int, Query(ge=1, le=MAX_LISTED)] = 100
) -> list[dict[str, Any]]:
    """Sessions with a membership history: live ones newest first, then the most
    recently ended."""
    return [_summary(e) for e in state.memberships.recent(limit)]


@router.get("/{session_id}", response_model=MembershipOut, responses=ERROR_RESPONSES)
async def get_membership(session_id: SessionId, state: State) -> dict[str, Any]:
    """One session's members now and its joins and leaves, oldest first."""
    entry = state.memberships.get(session_id)
    if entry is None:
        raise HTTPException(
            404, f"no membership history for session {shown(session_id)} (unknown or long ended)"
        )
    return {
        **_summary(entry),
        "definition": json_value(entry.record.definition),
        "changes": [
            {"time": round(c.time, 3), "node": c.node, "change": c.change} for c in entry.changes
        ],
        "dropped": entry.dropped,
    }
