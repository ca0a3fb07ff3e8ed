"""``/api/sessions``: list, read, start and stop interaction sessions.

Starting a session is all or nothing: when anything fails after the node began to
create it, every session the attempt left on that node is stopped again before the
error is answered, so a failed ``POST`` never leaves a session behind.
"""

from __future__ import annotations

import logging
from typing import Any

from fastapi import APIRouter, HTTPException, Path

from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.routes.views import session_detail, session_out
from dashboard.schemas import SessionDetailOut, SessionOut, StartSessionIn, StoppedOut
from dashboard.source import NodeHandle
from dashboard.state import ApiSession
from objectplaces import Initiator, ObjectPlacesError, Session
from objectplaces.groups import GroupDefinition

__all__ = ["router", "start_or_undo"]

log = logging.getLogger(__name__)

router = APIRouter(prefix="/api/sessions", tags=["sessions"])

SessionId = Path(max_length=256, description="the session's id; write '#' as '%23'")

# What a node or a role factory raises for input it cannot take: the client's fault.
_REFUSALS = (ObjectPlacesError, ValueError, TypeError, LookupError, ArithmeticError, RecursionError)


@router.get("", response_model=list[SessionOut])
async def list_sessions(state: State) -> list[dict[str, Any]]:
    """Every live session on every node, oldest first."""
    records = sorted(state.sessions().values(), key=lambda r: (r.started_at, r.session_id))
    now = state.source.now
    return [session_out(r, now) for r in records]


@router.get("/{session_id}", response_model=SessionDetailOut, responses=ERROR_RESPONSES)
async def get_session(state: State, session_id: str = SessionId) -> dict[str, Any]:
    """One session, with its initiator's report (a poll's answers). Session ids
    contain ``#``: encode it as ``%23`` in the path."""
    return session_detail(state, session_id)


@router.post(
    "",
    status_code=201,
    response_model=SessionDetailOut,
    responses=ERROR_RESPONSES,
)
async def start_session(body: StartSessionIn, state: State) -> dict[str, Any]:
    """Start a session on a node with a registered initiator role."""
    node = state.node(body.node, status=422)
    roles = state.roles()
    factory = roles.get(body.role)
    if factory is None:
        known = ", ".join(sorted(roles))
        raise HTTPException(422, f"unknown initiator role {shown(body.role)} (known: {known})")
    if state.api.full:
        raise HTTPException(
            429,
            f"{state.api.limit} sessions started over HTTP are live already; stop one first",
        )
    try:
        definition = body.definition.build()
    except ObjectPlacesError as exc:
        raise HTTPException(422, f"invalid group definition: {exc}") from exc
    try:
        initiator = factory(body.params)
    except _REFUSALS as exc:
        raise HTTPException(422, f"role {body.role!r} refused its params: {exc}") from exc
    handle = start_or_undo(node, initiator, definition, body.participant_role)
    sid = str(handle.session_id)
    state.api.add(
        sid,
        ApiSession(
            node=body.node,
            role=body.role,
            handle=handle,
            initiator=initiator,
            params=dict(body.params),
        ),
    )
    state.events.record(
        state.source.now, "info", "api", f"session {sid} ({body.role}) started over REST"
    )
    return session_detail(state, sid)


@router.delete(
    "/{session_id}",
    response_model=StoppedOut,
    responses=ERROR_RESPONSES,
)
async def stop_session(state: State, session_id: str = SessionId) -> StoppedOut:
    """Stop a session started through the API (the fleet's own are not ours to stop)."""
    api = state.api.get(session_id)
    if api is None:
        if session_id in state.sessions():
            raise HTTPException(
                409,
                f"session {session_id!r} belongs to the fleet; "
                "only sessions started through POST /api/sessions can be stopped",
            )
        raise HTTPException(404, f"unknown session {shown(session_id)}")
    state.api.pop(session_id)
    state.events.record(state.source.now, "info", "api", f"session {session_id} stopped over REST")
    ended = HTTPException(404, f"session {session_id!r} has already ended")
    node = state.source.nodes().get(api.node)
    if node is None:
        raise ended
    try:
        node.stop_interaction(api.handle)
    except ObjectPlacesError as exc:
        raise ended from exc
    return StoppedOut(id=session_id)


def start_or_undo(
    node: NodeHandle, initiator: Initiator, definition: GroupDefinition, participant_role: str
) -> Session:
    """``node.start_interaction``, or, when it raises, no trace of the attempt."""
    before = {str(info.session_id) for info in node.sessions()}
    try:
        return node.start_interaction(initiator, definition, participant_role)
    except BaseException as exc:
        for info in node.sessions():
            if str(info.session_id) not in before:
                _stop_quietly(node, str(info.session_id))
        if isinstance(exc, _REFUSALS):
            raise HTTPException(422, f"cannot start the session: {exc}") from exc
        raise


def _stop_quietly(node: NodeHandle, session_id: str) -> None:
    try:
        node.stop_interaction(session_id)
    except Exception:
        log.exception("could not undo session %s after a failed start", session_id)
