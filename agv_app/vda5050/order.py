"""A vehicle's VDA 5050 order, sans I/O: acceptance, updates, progress, node and edge states.

:class:`OrderBook` decides whether an incoming ``order`` message is taken, as VDA 5050
3.0 says (a new order, an update of the current one, a duplicate, or a rejection with an
error entry), and follows the vehicle along it: :meth:`OrderBook.reached` removes a
node (and the edge leading to it) from the states once the vehicle is there. Nodes are
the layout's points, edges its segments (``docs/vda5050.md``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from agv_app.layout.graph import Layout
from agv_app.vda5050.mapping import edge_fits
from agv_app.vda5050.validation import schema_errors

__all__ = ["OrderBook", "OrderEdge", "OrderNode", "OrderRejected", "Outcome", "VdaError"]

Outcome = Literal["accepted", "updated", "duplicate", "rejected"]


@dataclass(frozen=True, slots=True)
class VdaError:
    """One entry of a state's ``errors``.

    Attributes:
        error_type: e.g. ``validationError``, ``orderError``, ``orderUpdateError``,
            ``noRouteError``.
        description: what went wrong, for people.
        references: ``(referenceKey, referenceValue)`` pairs, e.g. ``("nodeId", "P1")``.
        level: ``WARNING`` (the vehicle carries on and takes new orders).
    """

    error_type: str
    description: str
    references: tuple[tuple[str, str], ...] = ()
    level: str = "WARNING"

    def to_json(self) -> dict[str, Any]:
        """The entry as the state message carries it."""
        return {
            "errorType": self.error_type,
            "errorLevel": self.level,
            "errorDescription": self.description,
            "errorReferences": [
                {"referenceKey": k, "referenceValue": v} for k, v in self.references
            ],
        }


class OrderRejected(Exception):
    """An order message that is not taken, with the error entry to report."""

    def __init__(self, error: VdaError) -> None:
        super().__init__(error.description)
        self.error = error


@dataclass(frozen=True, slots=True)
class OrderNode:
    """A node of an order: a layout point, its place in the order, base or horizon."""

    node_id: str
    sequence_id: int
    released: bool

    def to_json(self) -> dict[str, Any]:
        """The node's ``nodeState``."""
        return {"nodeId": self.node_id, "sequenceId": self.sequence_id, "released": self.released}


@dataclass(frozen=True, slots=True)
class OrderEdge:
    """An edge of an order: a layout segment, its place in the order, base or horizon."""

    edge_id: str
    sequence_id: int
    released: bool

    def to_json(self) -> dict[str, Any]:
        """The edge's ``edgeState``."""
        return {"edgeId": self.edge_id, "sequenceId": self.sequence_id, "released": self.released}


def _parse(order: Mapping[str, Any], layout: Layout) -> tuple[list[OrderNode], list[OrderEdge]]:
    """The nodes and edges of a schema-valid order, checked against each other and the layout.

    Raises:
        OrderRejected: validationError (sequence ids, base before horizon, edge count),
            orderError (actions, an empty base), noRouteError (a node or edge the
            layout does not have, or an edge not drivable between its nodes).
    """
    order_id = str(order["orderId"])
    ref = (("orderId", order_id),)
    raw_nodes = sorted(order["nodes"], key=lambda n: n["sequenceId"])
    raw_edges = sorted(order["edges"], key=lambda e: e["sequenceId"])
    if not raw_nodes:
        raise OrderRejected(VdaError("validationError", "an order needs at least one node", ref))
    if len(raw_edges) != len(raw_nodes) - 1:
        raise OrderRejected(
            VdaError(
                "validationError",
                f"{len(raw_nodes)} nodes need {len(raw_nodes) - 1} edges, got {len(raw_edges)}",
                ref,
            )
        )
    first = raw_nodes[0]["sequenceId"]
    nodes = [OrderNode(n["nodeId"], n["sequenceId"], n["released"]) for n in raw_nodes]
    edges = [OrderEdge(e["edgeId"], e["sequenceId"], e["released"]) for e in raw_edges]
    for i, node in enumerate(nodes):
        if node.sequence_id != first + 2 * i or node.sequence_id % 2:
            raise OrderRejected(
                VdaError(
                    "validationError",
                    "node sequenceIds must be even and step by 2 (edges take the odd ones)",
                    (*ref, ("nodeId", node.node_id)),
                )
            )
    for i, edge in enumerate(edges):
        if edge.sequence_id != first + 2 * i + 1:
            raise OrderRejected(
                VdaError(
                    "validationError",
                    "each edge's sequenceId must lie between its two nodes'",
                    (*ref, ("edgeId", edge.edge_id)),
                )
            )
    if not nodes[0].released:
        raise OrderRejected(VdaError("orderError", "the first node must be released", ref))
    for prev, node, edge in zip(nodes, nodes[1:], edges, strict=False):
        if (node.released and not prev.released) or edge.released != node.released:
            raise OrderRejected(
                VdaError(
                    "validationError",
                    "released nodes and edges must come first (the base), then the horizon",
                    (*ref, ("nodeId", node.node_id)),
                )
            )
    for item in [*raw_nodes, *raw_edges]:
        if item.get("actions"):
            action = item["actions"][0]
            raise OrderRejected(
                VdaError(
                    "orderError",
                    f"actions on nodes and edges are not supported ({action['actionType']!r})",
                    (*ref, ("actionId", str(action["actionId"]))),
                )
            )
    for node in nodes:
        if node.node_id not in layout.points:
            raise OrderRejected(
                VdaError(
                    "noRouteError",
                    f"node {node.node_id!r} is not on the layout",
                    (*ref, ("nodeId", node.node_id)),
                )
            )
    for a, b, edge in zip(nodes, nodes[1:], edges, strict=False):
        if not edge_fits(layout, a.node_id, b.node_id, edge.edge_id):
            raise OrderRejected(
                VdaError(
                    "noRouteError",
                    f"edge {edge.edge_id!r} is no segment drivable from {a.node_id!r} to "
                    f"{b.node_id!r}",
                    (*ref, ("edgeId", edge.edge_id)),
                )
            )
    return nodes, edges


@dataclass
class OrderBook:
    """The order a vehicle follows, as its ``state`` reports it.

    Args:
        layout: the floor plan the order's nodes and edges must be on.
        manufacturer: the vehicle's manufacturer (an order for another is rejected).
        serial_number: the vehicle's serial number.
        last_node_id: the point the vehicle stands on at first.
    """

    layout: Layout
    manufacturer: str
    serial_number: str
    last_node_id: str = ""
    order_id: str = ""
    order_update_id: int = 0
    last_node_sequence_id: int = 0
    nodes: list[OrderNode] = field(default_factory=list)
    """Nodes still to reach (``nodeStates``)."""
    edges: list[OrderEdge] = field(default_factory=list)
    """Edges still to drive (``edgeStates``)."""

    @property
    def active(self) -> bool:
        """True while some node of the order is still to be reached."""
        return bool(self.nodes)

    def base_end(self) -> OrderNode | None:
        """The last released node still to reach (None: no base left to drive)."""
        released = [n for n in self.nodes if n.released]
        return released[-1] if released else None

    def base_points(self) -> list[str]:
        """The points to drive through, from the last node reached to the base's end."""
        return [self.last_node_id, *(n.node_id for n in self.nodes if n.released)]

    def waiting_for_update(self) -> bool:
        """True when the base is driven and only the horizon is left."""
        return self.active and self.base_end() is None

    def receive(self, order: Any, *, at_rest: bool) -> Outcome:
        """Take an ``order`` message, or say why not.

        Args:
            order: the decoded message.
            at_rest: the vehicle stands on ``last_node_id`` and is not driving.

        Returns:
            ``accepted`` (a new order), ``updated`` (a later ``orderUpdateId`` of the
            current order), ``duplicate`` (the same ``orderUpdateId`` again: ignored).

        Raises:
            OrderRejected: the order is invalid or cannot be taken; nothing changed.
        """
        problems = schema_errors("order", order)
        if problems:
            raise OrderRejected(VdaError("validationError", "; ".join(problems)))
        order_id = str(order["orderId"])
        update_id = int(order["orderUpdateId"])
        ref: tuple[tuple[str, str], ...] = (
            ("orderId", order_id),
            ("orderUpdateId", str(update_id)),
        )
        if (order["manufacturer"], order["serialNumber"]) != (
            self.manufacturer,
            self.serial_number,
        ):
            raise OrderRejected(
                VdaError("validationError", "the order is for another vehicle", ref)
            )
        if order_id == self.order_id:
            if update_id < self.order_update_id:
                raise OrderRejected(
                    VdaError(
                        "orderUpdateError",
                        f"orderUpdateId {update_id} is older than {self.order_update_id}",
                        ref,
                    )
                )
            if update_id == self.order_update_id:
                return "duplicate"
            nodes, edges = _parse(order, self.layout)
            self._update(nodes, edges, ref)
            self.order_update_id = update_id
            return "updated"
        if self.active:
            raise OrderRejected(
                VdaError(
                    "orderError",
                    f"order {self.order_id!r} is still running: cancel it first",
                    ref,
                )
            )
        nodes, edges = _parse(order, self.layout)
        if nodes[0].node_id != self.last_node_id or not at_rest:
            raise OrderRejected(
                VdaError(
                    "noRouteError",
                    f"the order starts at {nodes[0].node_id!r}; the vehicle stands at "
                    f"{self.last_node_id!r}" + ("" if at_rest else " and is still driving"),
                    (*ref, ("nodeId", nodes[0].node_id)),
                )
            )
        self.order_id, self.order_update_id = order_id, update_id
        self.nodes, self.edges = nodes, edges
        self.reached(nodes[0].node_id)
        return "accepted"

    def _update(
        self,
        nodes: Sequence[OrderNode],
        edges: Sequence[OrderEdge],
        ref: tuple[tuple[str, str], ...],
    ) -> None:
        """Stitch an update on: its first node must be the current base's last node."""
        stitch = nodes[0]
        end = self.base_end()
        if end is None:
            # The base is driven: the update starts where the vehicle stands.
            ok = (stitch.node_id, stitch.sequence_id) == (
                self.last_node_id,
                self.last_node_sequence_id,
            )
        else:
            ok = (stitch.node_id, stitch.sequence_id) == (end.node_id, end.sequence_id)
        if not ok:
            raise OrderRejected(
                VdaError(
                    "orderUpdateError",
                    "an update must start at the last released node of the order",
                    (*ref, ("nodeId", stitch.node_id)),
                )
            )
        keep_nodes = [n for n in self.nodes if n.released and n.sequence_id < stitch.sequence_id]
        keep_edges = [e for e in self.edges if e.released and e.sequence_id < stitch.sequence_id]
        if end is None:
            self.nodes, self.edges = list(nodes[1:]), list(edges)
        else:
            self.nodes, self.edges = [*keep_nodes, *nodes], [*keep_edges, *edges]

    def reached(self, node_id: str) -> bool:
        """The vehicle is at ``node_id``: if it is the next node, it leaves the states.

        Returns:
            True if the node was the next one of the order.
        """
        if not self.nodes or self.nodes[0].node_id != node_id:
            if not self.nodes:
                self.last_node_id = node_id
            return False
        node = self.nodes.pop(0)
        if self.edges and self.edges[0].sequence_id < node.sequence_id:
            self.edges.pop(0)
        self.last_node_id, self.last_node_sequence_id = node.node_id, node.sequence_id
        return True

    def cancel(self) -> None:
        """Drop every node and edge still to go; the order id stays, as the spec says."""
        self.nodes.clear()
        self.edges.clear()
