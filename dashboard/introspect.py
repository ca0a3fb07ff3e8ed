"""Reading a middleware node (a ``NodeHandle``, e.g. ``objectplaces.RoleActivator``) into
dashboard records.

All knowledge of the node's introspection API lives here, so the rest of the dashboard
deals in ``SessionRecord`` and plain dicts.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from dashboard.capture import SessionRecord
from dashboard.source import NodeHandle
from objectplaces import NodeStats

__all__ = [
    "counters_of",
    "participations_of",
    "properties_of",
    "sessions_of",
    "view_of",
]


def sessions_of(node_id: str, node: NodeHandle) -> list[SessionRecord]:
    """The live sessions ``node`` initiated, oldest first.

    Args:
        node_id: the node's id (the initiator of each record).
        node: the node handle.
    """
    return [
        SessionRecord(
            session_id=str(info.session_id),
            node=node_id,
            role=str(info.initiator_role),
            participant_role=str(info.participant_role),
            members=tuple(sorted(info.members)),
            started_at=float(info.started_at),
            definition=info.definition,
        )
        for info in node.sessions()
    ]


def participations_of(node: NodeHandle) -> list[dict[str, Any]]:
    """The participant roles active on ``node``: ``{session_id, initiator, role}``."""
    return [
        {"session_id": str(p.session_id), "initiator": str(p.initiator), "role": p.participant_role}
        for p in node.participations()
    ]


def properties_of(node: NodeHandle) -> Mapping[str, Any]:
    """The node's own current properties."""
    return node.properties


def view_of(node: NodeHandle) -> Mapping[str, Mapping[str, Any]]:
    """The latest properties ``node`` knows of every other node, by node id."""
    view = node.view()
    return {k: view[k] for k in sorted(view)}


def counters_of(node: NodeHandle, *, full: bool = False) -> dict[str, Any]:
    """The node's traffic: ``messages`` and ``bytes`` sent plus received, and ``sent``
    (messages sent).

    Args:
        node: the node handle.
        full: also include ``sent`` and ``received`` as ``{kind: [messages, bytes]}``
            and the node's drop ``counters`` (for the node detail).
    """
    stats = node.stats()
    out: dict[str, Any] = {
        "messages": int(stats.messages_sent + stats.messages_received),
        "bytes": int(stats.bytes_sent + stats.bytes_received),
        "sent": int(stats.messages_sent),
    }
    if full:
        out.update(_plain(stats))
    return out


def _plain(stats: NodeStats) -> dict[str, Any]:
    return {
        "sent": {k: list(v) for k, v in stats.sent.items()},
        "received": {k: list(v) for k, v in stats.received.items()},
        "counters": dict(stats.counters),
    }
