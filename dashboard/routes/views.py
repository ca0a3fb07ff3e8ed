"""Session records in the JSON form the REST API answers with."""

from __future__ import annotations

from typing import Any

from fastapi import HTTPException

from dashboard.capture import SessionRecord
from dashboard.limits import shown
from dashboard.state import DashboardState
from objectplaces.json_form import json_value

__all__ = ["session_detail", "session_out"]


def session_out(rec: SessionRecord, now: float) -> dict[str, Any]:
    """A live session as ``SessionOut`` at simulated time ``now``."""
    return {
        "id": rec.session_id,
        "node": rec.node,
        "role": rec.role,
        "participant_role": rec.participant_role,
        "members": sorted(rec.members),
        "started_at": rec.started_at,
        "age_s": max(0.0, now - rec.started_at),
        "definition": json_value(rec.definition),
        "via_api": rec.via_api,
    }


def session_detail(state: DashboardState, session_id: str) -> dict[str, Any]:
    """A live session as ``SessionDetailOut``, with its parameters and its initiator's
    report (a poll's answers).

    Raises:
        HTTPException: 404, no live session has that id.
    """
    rec = state.sessions().get(session_id)
    if rec is None:
        raise HTTPException(
            404, f"unknown session {shown(session_id)} (it never existed or has ended)"
        )
    out = session_out(rec, state.source.now)
    api = state.api.get(session_id)
    out["params"] = json_value(api.params) if api else {}
    report = getattr(api.initiator, "detail", None) if api else None
    out["detail"] = json_value(report()) if callable(report) else None
    return out
