"""A vehicle's VDA 5050 order, sans I/O: acceptance, updates, progress, node and edge states.

:func:`parse_order` (:mod:`agv_app.vda5050.order_parsing`, re-exported here with the
other names of the parsed order) checks an ``order`` message as a whole, in the order
VDA 5050 3.0 asks, and rejects it with the 3.0 error of the first problem found.

:class:`OrderBook` then decides whether it is a new order, an update of the current
one, a duplicate, or none of these (``OTHER_ORDER_ACTIVE``, ``START_NODE_OUT_OF_RANGE``,
``OUTDATED_ORDER_UPDATE``, ``SAME_ORDER_UPDATE_ID``, ``ORDER_UPDATE_FOLLOWING_CANCEL``),
and follows the vehicle along it: :meth:`OrderBook.reached` removes a node (and the
edge leading to it) from the states once the vehicle is there and triggers the node's
actions (:class:`~agv_app.vda5050.actions.ActionBook`). Nodes are the layout's points,
edges its segments (``docs/vda5050.md``).
"""

from __future__ import annotations

from typing import Any, Literal

from agv_app.layout.graph import Layout
from agv_app.vda5050.actions import ActionBook
from agv_app.vda5050.order_parsing import (
    NODE_POSITION_TOLERANCE_M,
    OPTIONAL_PARAMETERS,
    OrderEdge,
    OrderNode,
    OrderRejected,
    ParsedOrder,
    parse_order,
    reject,
)
from agv_app.vda5050.reports import (
    ORDER_UPDATE_FOLLOWING_CANCEL,
    OTHER_ORDER_ACTIVE,
    OUTDATED_ORDER_UPDATE,
    SAME_ORDER_UPDATE_ID,
    START_NODE_OUT_OF_RANGE,
)

__all__ = [
    "NODE_POSITION_TOLERANCE_M",
    "OPTIONAL_PARAMETERS",
    "OrderBook",
    "OrderEdge",
    "OrderNode",
    "OrderRejected",
    "Outcome",
    "ParsedOrder",
    "parse_order",
]

Outcome = Literal["accepted", "updated", "duplicate"]
"""What :meth:`OrderBook.receive` did with an order message."""


class OrderBook:
    """The order a vehicle follows, as its ``state`` reports it.

    Args:
        layout: the floor plan the order's nodes and edges must be on.
        manufacturer: the vehicle's manufacturer (an order for another is rejected).
        serial_number: the vehicle's serial number.
        actions: the order's action states (filled from each order taken).
        last_node_id: the point the vehicle stands on at first.
    """

    def __init__(
        self,
        layout: Layout,
        manufacturer: str,
        serial_number: str,
        *,
        actions: ActionBook,
        last_node_id: str = "",
    ) -> None:
        self.layout = layout
        self.manufacturer = manufacturer
        self.serial_number = serial_number
        self.actions = actions
        self.last_node_id = last_node_id
        self.order_id = ""
        self.order_update_id = 0
        self.last_node_sequence_id = 0
        self.nodes: list[OrderNode] = []
        """Nodes still to reach (``nodeStates``)."""
        self.edges: list[OrderEdge] = []
        """Edges still to drive (``edgeStates``)."""
        self.cancelled = False
        """The current order was cancelled (its updates are refused)."""
        self._content = ""

    @property
    def active(self) -> bool:
        """True while a node is still to be reached or an action has not ended (the
        vehicle is not idle, VDA 5050 3.0 section 6.6.8)."""
        return bool(self.nodes) or not self.actions.idle

    def base_end(self) -> OrderNode | None:
        """The last released node still to reach (None: no base left to drive)."""
        released = [n for n in self.nodes if n.released]
        return released[-1] if released else None

    def base_points(self) -> list[str]:
        """The points to drive through next: from the last node reached to the base's
        end, or to the first node before it where an action stops the vehicle."""
        points = [self.last_node_id]
        for node in self.nodes:
            if not node.released:
                break
            points.append(node.node_id)
            if any(
                r.status == "WAITING" and r.action.blocking_type in ("SOFT", "HARD")
                for r in self.actions.at(node.sequence_id)
            ):
                break
        return points

    def waiting_for_update(self) -> bool:
        """True when the base is driven and only the horizon is left."""
        return bool(self.nodes) and self.base_end() is None

    def receive(self, message: Any, *, at_rest: bool, now: float) -> Outcome:
        """Take an ``order`` message, or say why not.

        Args:
            message: the decoded message.
            at_rest: the vehicle stands on ``last_node_id`` and is not driving.
            now: the vehicle's clock (the first node's actions start at once).

        Returns:
            ``accepted`` (a new order), ``updated`` (a later ``orderUpdateId`` of the
            current order), ``duplicate`` (the same message again: ignored).

        Raises:
            OrderRejected: the order is invalid or cannot be taken; nothing changed.
        """
        order = parse_order(
            message, self.layout, manufacturer=self.manufacturer, serial_number=self.serial_number
        )
        ref = order.ref
        if order.order_id == self.order_id:
            if order.update_id < self.order_update_id:
                reject(
                    OUTDATED_ORDER_UPDATE,
                    f"orderUpdateId {order.update_id} is older than {self.order_update_id}",
                    ref,
                )
            if self.cancelled:
                reject(
                    ORDER_UPDATE_FOLLOWING_CANCEL, f"order {order.order_id!r} was cancelled", ref
                )
            if order.update_id == self.order_update_id:
                if order.content == self._content:
                    return "duplicate"
                reject(
                    SAME_ORDER_UPDATE_ID,
                    f"orderUpdateId {order.update_id} came before with other content",
                    ref,
                )
            self._update(order)
            return "updated"
        if self.active:
            reject(
                OTHER_ORDER_ACTIVE,
                f"order {self.order_id!r} is still active: cancel it first",
                ref,
            )
        first = order.nodes[0]
        if first.node_id != self.last_node_id or not at_rest:
            reject(
                START_NODE_OUT_OF_RANGE,
                f"the order starts at {first.node_id!r}; the vehicle stands at "
                f"{self.last_node_id!r}" + ("" if at_rest else " and is still driving"),
                (*ref, ("nodeId", first.node_id)),
            )
        self.order_id, self.order_update_id = order.order_id, order.update_id
        self.nodes, self.edges = list(order.nodes), list(order.edges)
        self.cancelled = False
        self._content = order.content
        self.actions.replace(list(order.actions))
        self.reached(first.node_id, now)
        return "accepted"

    def _update(self, order: ParsedOrder) -> None:
        """Stitch an update on: its first node must be the current base's last node."""
        stitch = order.nodes[0]
        end = self.base_end()
        # With the base driven, the update starts where the vehicle stands.
        at = (
            (self.last_node_id, self.last_node_sequence_id)
            if end is None
            else (end.node_id, end.sequence_id)
        )
        if (stitch.node_id, stitch.sequence_id) != at:
            reject(
                START_NODE_OUT_OF_RANGE,
                f"an update must start at the order's decision point {at[0]!r} (sequenceId "
                f"{at[1]}), not at {stitch.node_id!r} ({stitch.sequence_id})",
                (*order.ref, ("nodeId", stitch.node_id)),
            )
        keep_nodes = [n for n in self.nodes if n.released and n.sequence_id < stitch.sequence_id]
        keep_edges = [e for e in self.edges if e.released and e.sequence_id < stitch.sequence_id]
        if end is None:
            self.nodes, self.edges = list(order.nodes[1:]), list(order.edges)
        else:
            self.nodes, self.edges = [*keep_nodes, *order.nodes], [*keep_edges, *order.edges]
        self.actions.update(stitch.sequence_id, list(order.actions))
        self.order_update_id = order.update_id
        self._content = order.content

    def reached(self, node_id: str, now: float) -> bool:
        """The vehicle is at ``node_id``: if it is the next node, it leaves the states
        and its actions start.

        Returns:
            True if the node was the next one of the order.
        """
        if not self.nodes or self.nodes[0].node_id != node_id:
            if not self.nodes:
                self.last_node_id = node_id  # no order to follow: it is where it stands
            return False
        node = self.nodes.pop(0)
        if self.edges and self.edges[0].sequence_id < node.sequence_id:
            self.edges.pop(0)
        self.last_node_id, self.last_node_sequence_id = node.node_id, node.sequence_id
        self.actions.trigger(node.sequence_id, now)
        return True

    def stand_at(self, node_id: str) -> None:
        """The vehicle stands on ``node_id`` with no order to follow (initializePosition)."""
        self.last_node_id = node_id

    def cancel(self) -> bool:
        """Drop every node and edge still to go and cancel the actions; the order id
        stays, as the spec says.

        Returns:
            True once no action of the order runs any more.
        """
        self.nodes.clear()
        self.edges.clear()
        self.cancelled = True
        return self.actions.cancel()
