"""How the layout maps to VDA 5050: nodes are points, edges are segments.

A node's ``nodeId`` is the point's id. An edge is a segment driven in one direction:
driven from its ``start`` to its ``end`` its ``edgeId`` is the segment's id; a
two-way segment driven the other way is ``<segment id>~rev`` (the LIF export lists
both, as LIF edges are directed). An order may also name a two-way segment by its
plain id in either direction.
"""

from __future__ import annotations

from agv_app.layout.graph import Layout

__all__ = ["REVERSE_SUFFIX", "edge_fits", "vda_edge_id"]

REVERSE_SUFFIX = "~rev"
"""Appended to a two-way segment's id for the edge driven from its end to its start."""


def vda_edge_id(layout: Layout, a: str, b: str) -> str | None:
    """The ``edgeId`` of the edge driven from point ``a`` to point ``b`` (None: none)."""
    segment = layout.segment_between(a, b)
    if segment is None:
        return None
    return segment if layout.segment(segment).start == a else segment + REVERSE_SUFFIX


def edge_fits(layout: Layout, a: str, b: str, edge_id: str) -> bool:
    """True if ``edge_id`` names a segment drivable from point ``a`` to point ``b``."""
    segment = layout.segment_between(a, b)
    return segment is not None and edge_id in (segment, vda_edge_id(layout, a, b))
