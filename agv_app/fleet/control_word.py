"""How an AGV process hears one property of the control, and nobody else's.

The control publishes the operator's word as properties of the observer
(:data:`~agv_app.fleet.view.OBSERVER_ID`): the stop, the closed ways, the requests to
go home and the charging orders. The observer has no position, so each property
reaches every node, and a vehicle that joins later hears it with the observer's other
properties. A node's id is the common name of its certificate, which only the control
host holds (docs/security.md), so the same property published by any other node is
ignored, and counted, as is a value its listener finds malformed.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from agv_app.fleet.view import OBSERVER_ID
from objectplaces import RoleActivator

__all__ = ["ControlWord"]


class ControlWord:
    """Follows the control's property ``name`` on ``node``: ``hear`` takes each value
    the control publishes, the one it holds now first.

    Args:
        node: the AGV's node.
        name: the control's property.
        hear: takes one value; False when the value is malformed (nothing changes).
        control_id: the only node whose word counts (the observer).
    """

    def __init__(
        self,
        node: RoleActivator,
        name: str,
        hear: Callable[[Any], bool],
        *,
        control_id: str = OBSERVER_ID,
    ) -> None:
        self.control_id = control_id
        self.refused = 0
        """Values from another node than the control, or malformed, ignored."""
        self._hear = hear
        node.register_node_property_observer(self._property, names=(name,))
        told = node.view().get(control_id, {}).get(name)
        if told is not None:
            self._property(control_id, name, told)

    def _property(self, node_id: str, name: str, value: Any) -> None:
        if node_id != self.control_id or not self._hear(value):
            self.refused += 1
