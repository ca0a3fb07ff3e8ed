"""``GET /api/nodes`` and ``GET /api/nodes/{id}``: the middleware nodes, read only."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from dashboard import introspect
from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.routes.views import session_out
from dashboard.schemas import NodeDetailOut, NodeOut, ParticipationOut
from dashboard.source import NodeHandle
from objectplaces.json_form import json_value

__all__ = ["node_out", "router"]

router = APIRouter(prefix="/api/nodes", tags=["nodes"])


def node_out(node_id: str, node: NodeHandle) -> dict[str, Any]:
    """One node as ``NodeOut``: its own properties, role counts and traffic."""
    counters = introspect.counters_of(node)
    return {
        "id": node_id,
        "properties": json_value(dict(introspect.properties_of(node))),
        "initiated": len(introspect.sessions_of(node_id, node)),
        "participating": len(introspect.participations_of(node)),
        "messages": int(counters.get("messages", 0)),
        "bytes": int(counters.get("bytes", 0)),
    }


@router.get("", response_model=list[NodeOut])
async def list_nodes(state: State) -> list[dict[str, Any]]:
    """Every node: its own properties, role counts and traffic."""
    nodes = state.source.nodes()
    return [node_out(node_id, nodes[node_id]) for node_id in sorted(nodes)]


@router.get("/{node_id}", response_model=NodeDetailOut, responses=ERROR_RESPONSES)
async def get_node(node_id: str, state: State) -> dict[str, Any]:
    """One node in full: sessions it initiated, roles it plays, counters, its view."""
    node = state.node(node_id)
    sessions = state.sessions()
    now = state.source.now
    out = node_out(node_id, node)
    out["sessions"] = [
        session_out(sessions.get(r.session_id, r), now)
        for r in introspect.sessions_of(node_id, node)
    ]
    out["participations"] = [
        ParticipationOut(**p).model_dump() for p in introspect.participations_of(node)
    ]
    out["stats"] = json_value(dict(introspect.counters_of(node, full=True)))
    out["view"] = {k: json_value(dict(v)) for k, v in introspect.view_of(node).items()}
    return out
