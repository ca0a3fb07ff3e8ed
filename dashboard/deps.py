"""Dependencies shared by the routes: the dashboard's state.

``async`` so FastAPI runs it on the event loop, never on a worker thread. Who may call
what is decided before any route runs (``dashboard.guard``).
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends
from starlette.requests import HTTPConnection

from dashboard.state import DashboardState

__all__ = ["State", "dashboard_state"]


async def dashboard_state(connection: HTTPConnection) -> DashboardState:
    """The state of the app serving this request or WebSocket."""
    state = connection.app.state.dashboard
    assert isinstance(state, DashboardState)
    return state


State = Annotated[DashboardState, Depends(dashboard_state)]
"""A route parameter that receives the dashboard's state."""
