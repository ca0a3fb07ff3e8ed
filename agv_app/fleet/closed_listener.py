"""How an AGV process hears what the operator closed (the process fleet).

The control publishes the closed points and segments as the observer's property
``closed`` (:data:`CLOSED_PROPERTY`, ``[[point ids], [segment ids]]``, both sorted),
as it publishes the operator's stop (:mod:`agv_app.fleet.holding`): the observer has
no position, so the property reaches every node, and a vehicle that joins later hears it
with the observer's other properties. Each AGV process follows it with a
:class:`ClosedListener`, which hands the open ways to its AGV component
(:mod:`agv_app.vehicle.closures`). Only the observer's word counts; the property from
any other node, or one that names an element the layout lacks, is ignored and counted.
"""

from __future__ import annotations

from typing import Any

from agv_app.fleet.blocks import Routed
from agv_app.fleet.control_word import ControlWord
from agv_app.fleet.view import OBSERVER_ID
from agv_app.layout.blocked import Closed, OpenWays
from agv_app.layout.graph import Layout
from objectplaces import RoleActivator

__all__ = ["CLOSED_PROPERTY", "ClosedListener", "closed_in", "closed_wire"]

CLOSED_PROPERTY = "closed"
"""The observer's property: ``[[closed point ids], [closed segment ids]]``."""


def closed_wire(ways: OpenWays | None) -> list[list[str]]:
    """The wire form of what ``ways`` keeps closed (nothing for None)."""
    if ways is None:
        return [[], []]
    return [sorted(ways.closed.points), sorted(ways.closed.segments)]


def closed_in(value: Any, layout: Layout) -> Closed | None:
    """What the wire form ``value`` closes on ``layout``; None if it is malformed or
    names a point or segment the layout lacks."""
    if not (isinstance(value, list | tuple) and len(value) == 2):
        return None
    points, segments = value
    if not all(isinstance(ids, list | tuple) for ids in (points, segments)):
        return None
    if not all(isinstance(p, str) and p in layout.points for p in points):
        return None
    if not all(isinstance(s, str) and s in layout.segments for s in segments):
        return None
    return Closed(frozenset(points), frozenset(segments))


class ClosedListener:
    """An AGV's ear for the closed parts of the floor: sets ``agv.ways`` as the
    observer's :data:`CLOSED_PROPERTY` says, and nobody else's.

    Args:
        node: the AGV's node.
        agv: its component.
        layout: the floor plan it drives.
        control_id: the only node whose word counts (the observer).
    """

    def __init__(
        self,
        node: RoleActivator,
        agv: Routed,
        layout: Layout,
        *,
        control_id: str = OBSERVER_ID,
    ) -> None:
        self.agv = agv
        self.layout = layout
        self.word = ControlWord(node, CLOSED_PROPERTY, self._heard, control_id=control_id)

    @property
    def refused(self) -> int:
        """Closed properties from another node than the control, or malformed, ignored."""
        return self.word.refused

    def _heard(self, value: Any) -> bool:
        closed = closed_in(value, self.layout)
        if closed is None:
            return False
        ways = self.agv.ways
        if ways is None or ways.closed != closed:
            self.agv.ways = None if closed.empty else OpenWays(self.layout, closed)
        return True
