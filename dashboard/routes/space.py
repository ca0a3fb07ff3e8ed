"""``GET /api/nodes/{id}/space``: what a node's tuplespace holds, a page at a time."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, HTTPException, Path, Query
from pydantic import BaseModel, ConfigDict, Field

from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.space import MAX_SPACE_PAGE, space_of

__all__ = ["MAX_SPACE_OFFSET", "SpaceOut", "router"]

router = APIRouter(prefix="/api/nodes", tags=["nodes"])

MAX_SPACE_OFFSET = 1_000_000
"""The largest offset asked for."""

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
    live there), and how many it holds. 404 names the known nodes; 409 for a node that
    runs in another process, whose space this process cannot read."""
    node = state.node(node_id)
    page = space_of(node, offset=offset, limit=limit)
    if page is None:
        raise HTTPException(
            409,
            f"node {shown(node_id)} runs in its own process: its tuplespace is not "
            "readable from the dashboard",
        )
    total, tuples = page
    return SpaceOut(node=node_id, total=total, offset=offset, limit=limit, tuples=tuples)
