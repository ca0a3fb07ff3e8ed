"""What a node's tuplespace holds, read a page at a time for ``GET /api/nodes/{id}/space``.

A node in this process (``objectplaces.RoleActivator``, which has a ``space``) is read
directly: every live tuple, by arity and then oldest first, each field in plain JSON
(:func:`~dashboard.schemas.json_value`; an object without a JSON form is its ``repr``).
A node that runs in another process (an AGV process of ``demo --processes``, seen
through ``agv_app.fleet.remote.RemoteNode``) keeps its space there: nothing that node
publishes carries it, so :func:`space_of` says so (None).
"""

from __future__ import annotations

from typing import Any

from dashboard.source import NodeHandle
from objectplaces.json_form import json_value
from tuplespace import TupleSpace
from tuplespace.paging import page

__all__ = ["MAX_SPACE_PAGE", "SpacePage", "space_of"]

MAX_SPACE_PAGE = 500
"""Most tuples one page holds."""

SpacePage = tuple[int, list[list[Any]]]
"""How many tuples the space holds in all, and the page asked for."""


def space_of(node: NodeHandle, *, offset: int, limit: int) -> SpacePage | None:
    """Tuples ``offset`` to ``offset + limit`` of ``node``'s space (by arity, then oldest
    first), and the total; None when the node's space is not in this process.

    Raises:
        ValueError: ``offset`` < 0, or ``limit`` not in 1..``MAX_SPACE_PAGE``.
    """
    if offset < 0 or not 1 <= limit <= MAX_SPACE_PAGE:
        raise ValueError(f"offset must be >= 0 and limit 1..{MAX_SPACE_PAGE}")
    space = getattr(node, "space", None)
    if not isinstance(space, TupleSpace):
        return None
    total, tuples = page(space, offset, limit)
    return total, [[json_value(f) for f in tup] for tup in tuples]
