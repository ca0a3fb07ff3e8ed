"""``GET /api/groups/view``: which nodes a definition selects, without a session."""

from __future__ import annotations

import json
from typing import Annotated

from fastapi import APIRouter, HTTPException, Query
from pydantic import ValidationError

from dashboard.definitions import MAX_NAME_LENGTH, definition_adapter
from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES, describe
from dashboard.limits import MAX_JSON_DEPTH, json_depth
from dashboard.schemas import GroupViewOut
from objectplaces import ObjectPlacesError

__all__ = ["MAX_DEFINITION_CHARS", "router"]

router = APIRouter(prefix="/api/groups", tags=["groups"])

MAX_DEFINITION_CHARS = 8192
"""Longest ``definition`` parameter accepted."""


@router.get("/view", response_model=GroupViewOut, responses=ERROR_RESPONSES)
async def view_group(
    state: State,
    definition: Annotated[
        str,
        Query(
            max_length=MAX_DEFINITION_CHARS,
            description="a declarative group definition as JSON",
            examples=['{"type": "within", "distance": 20}'],
        ),
    ],
    node: Annotated[
        str | None,
        Query(
            max_length=MAX_NAME_LENGTH,
            description="the would-be initiator's node id (default: the observer)",
        ),
    ] = None,
) -> GroupViewOut:
    """Which nodes a definition selects from a node's point of view, without a session."""
    node_id = state.source.observer_id if node is None else node
    handle = state.node(node_id)
    depth = json_depth(definition)
    if depth > MAX_JSON_DEPTH:
        raise HTTPException(
            422, f"definition nests {depth} levels deep; at most {MAX_JSON_DEPTH} allowed"
        )
    try:
        raw = json.loads(definition)
    except ValueError as exc:  # JSONDecodeError, and numbers too long to convert
        raise HTTPException(400, f"definition is not valid JSON: {exc}") from exc
    try:
        model = definition_adapter.validate_python(raw)
    except ValidationError as exc:
        problems = describe(exc.errors(), where="definition")
        raise HTTPException(422, f"invalid group definition: {problems}") from exc
    try:
        defn = model.build()
    except ObjectPlacesError as exc:
        raise HTTPException(422, f"invalid group definition: {exc}") from exc
    try:
        members = handle.view_group(defn)
    except ObjectPlacesError as exc:  # a node in another process keeps its view there
        raise HTTPException(422, f"cannot view the group: {exc}") from exc
    return GroupViewOut(node=node_id, definition=defn.to_json(), members=sorted(members))
