"""``GET /api/nodes/{id}/space``: what a node's tuplespace holds, a page at a time."""

from __future__ import annotations

import asyncio
from typing import Annotated

from fastapi import APIRouter, HTTPException, Path, Query
from pydantic import BaseModel, ConfigDict, Field

from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.space import MAX_SPACE_PAGE, SpacePage, space_of
from dashboard.state import DashboardState
from objectplaces import RoleActivator
from objectplaces.space_pages import MAX_OFFSET, MAX_PAGE, SpaceUnreadable, read_space

__all__ = ["MAX_SPACE_OFFSET", "REMOTE_SPACE_TIMEOUT_S", "SpaceOut", "router"]

router = APIRouter(prefix="/api/nodes", tags=["nodes"])

MAX_SPACE_OFFSET = MAX_OFFSET
"""The largest offset asked for."""

REMOTE_SPACE_TIMEOUT_S = 5.0
"""How long a node in another process has to answer."""

NodeId = Annotated[str, Path(min_length=1, max_length=128)]


class SpaceOut(BaseModel):
    """A page of a node's tuplespace."""

    model_config = ConfigDict(extra="forbid")

    node: str
    total: int = Field(description="tuples the space holds in all")
    offset: int
    limit: int
    tuples: list[list[object]] = Field(
        description="by arity, then oldest first; each field in plain JSON (else its repr)"
    )


@router.get("/{node_id}/space", response_model=SpaceOut, responses=ERROR_RESPONSES)
async def get_space(
    node_id: NodeId,
    state: State,
    offset: Annotated[int, Query(ge=0, le=MAX_SPACE_OFFSET)] = 0,
    limit: Annotated[int, Query(ge=1, le=MAX_SPACE_PAGE)] = 100,
) -> SpaceOut:
    """Tuples ``offset`` to ``offset + limit`` of the node's tuplespace (a vehicle's locks
    live there), and how many it holds. A node in another process (an AGV process) is
    asked by the dashboard's observer node, as one session of the role
    ``space-pages``; its answer may hold fewer tuples than asked (page on from
    ``offset + len(tuples)``). 404 names the known nodes; 409 for a node that serves no
    tuplespace to the dashboard or refused; 504 when it did not answer within
    ``REMOTE_SPACE_TIMEOUT_S``."""
    node = state.node(node_id)
    page = space_of(node, offset=offset, limit=limit)
    if page is None:
        page = await _remote_page(state, node_id, offset, min(limit, MAX_PAGE))
    total, tuples = page
    return SpaceOut(node=node_id, total=total, offset=offset, limit=limit, tuples=tuples)


async def _remote_page(state: DashboardState, node_id: str, offset: int, limit: int) -> SpacePage:
    reader = state.source.nodes().get(state.source.observer_id)
    if not isinstance(reader, RoleActivator):
        raise HTTPException(409, f"node {shown(node_id)} runs in another process, out of reach")
    try:
        async with asyncio.timeout(REMOTE_SPACE_TIMEOUT_S):
            return await read_space(reader, node_id, offset=offset, limit=limit)
    except SpaceUnreadable as exc:
        raise HTTPException(409, str(exc)[:300]) from exc
    except TimeoutError as exc:
        raise HTTPException(
            504, f"node {shown(node_id)} did not answer within {REMOTE_SPACE_TIMEOUT_S:g} s"
        ) from exc
