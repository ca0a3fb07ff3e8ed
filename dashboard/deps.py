"""Dependencies shared by the routes: the dashboard's state and the token check.

Both are ``async`` so FastAPI runs them on the event loop, never on a worker thread.
"""

from __future__ import annotations

import hmac
from typing import Annotated

from fastapi import Depends, Header, HTTPException
from starlette.requests import HTTPConnection

from dashboard.state import DashboardState

__all__ = ["State", "dashboard_state", "require_token"]


async def dashboard_state(connection: HTTPConnection) -> DashboardState:
    """The state of the app serving this request or WebSocket."""
    state = connection.app.state.dashboard
    assert isinstance(state, DashboardState)
    return state


State = Annotated[DashboardState, Depends(dashboard_state)]
"""A route parameter that receives the dashboard's state."""


async def require_token(
    state: State, authorization: Annotated[str | None, Header(max_length=4096)] = None
) -> None:
    """Refuse a mutating request without the configured token (401).

    Raises:
        HTTPException: a token is configured and the request does not carry it.
    """
    if state.token is None:
        return
    scheme, _, given = (authorization or "").partition(" ")
    if scheme.lower() != "bearer" or not hmac.compare_digest(given.encode(), state.token.encode()):
        raise HTTPException(
            401,
            "this server needs a token for changes: send 'Authorization: Bearer <token>'",
            headers={"WWW-Authenticate": "Bearer"},
        )
