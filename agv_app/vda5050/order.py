"""A vehicle's VDA 5050 order, sans I/O: acceptance, updates, progress, node and edge states.

:func:`parse_order` checks an ``order`` message as a whole, in the order VDA 5050 3.0
asks (Figure 8 and section 6.1.4): the schema and the header (``VALIDATION_FAILURE``),
the optional fields (``UNSUPPORTED_PARAMETER``, :data:`OPTIONAL_PARAMETERS` lists those
the vehicle takes), the maps (``UNKNOWN_MAP_ID``), the route on the layout
(``NO_ROUTE_TO_TARGET``) and the actions (``INVALID_ORDER_ACTION``).

:class:`OrderBook` then decides whether it is a new order, an update of the current
one, a duplicate, or none of these (``OTHER_ORDER_ACTIVE``, ``START_NODE_OUT_OF_RANGE``,
``OUTDATED_ORDER_UPDATE``, ``SAME_ORDER_UPDATE_ID``, ``ORDER_UPDATE_FOLLOWING_CANCEL``),
and follows the vehicle along it: :meth:`OrderBook.reached` removes a node (and the
edge leading to it) from the states once the vehicle is there and triggers the node's
actions (:class:`~agv_app.vda5050.actions.ActionBook`). Nodes are the layout's points,
edges its segments (``docs/vda5050.md``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final, Literal

from agv_app.layout.graph import Layout
from agv_app.vda5050.actions import CATALOGUE, ActionBook, OrderAction
from agv_app.vda5050.handling import node_action_problem
from agv_app.vda5050.mapping import edge_fits
from agv_app.vda5050.reports import (
    CRITICAL,
    INVALID_ORDER_ACTION,
    NO_ROUTE_TO_TARGET,
    ORDER_UPDATE_FOLLOWING_CANCEL,
    OTHER_ORDER_ACTIVE,
    OUTDATED_ORDER_UPDATE,
    SAME_ORDER_UPDATE_ID,
    START_NODE_OUT_OF_RANGE,
    UNKNOWN_MAP_ID,
    UNSUPPORTED_PARAMETER,
    VALIDATION_FAILURE,
    VdaError,
)
from agv_app.vda5050.validation import schema_errors

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

NODE_POSITION_TOLERANCE_M: Final = 0.05
"""How far an order's ``nodePosition`` may be from the layout's point of that id."""

OPTIONAL_PARAMETERS: Final[Mapping[str, str]] = {
    "order.orderDescription": "kept for people; no logic uses it",
    "order.nodes.nodeDescriptor": "kept for people; no logic uses it",
    "order.nodes.nodePosition": "x and y must be the layout point's (5 cm), mapId the "
    "layout's name",
    "order.nodes.nodePosition.allowedDeviationXY": "met always: the vehicle passes every "
    "node's exact position",
    "order.nodes.nodePosition.allowedDeviationTheta": "met always: theta is not supported, "
    "so no orientation is asked",
    "order.nodes.actions.actionDescriptor": "kept for people; no logic uses it",
    "order.nodes.actions.actionParameters": "as the factsheet's mobileRobotActions list them",
    "order.nodes.actions.retriable": "false only: an action that fails is FAILED",
    "order.edges.edgeDescriptor": "kept for people; no logic uses it",
    "order.edges.length": "the vehicle knows its edges' lengths; the value is not used",
}
"""The optional fields of an order the vehicle takes, with what it does with each (the
factsheet's ``optionalParameters``, all 'SUPPORTED'). An order with any other optional
field is rejected with ``UNSUPPORTED_PARAMETER``: the vehicle would not honour it."""

_HEADER: Final = frozenset({"headerId", "timestamp", "version", "manufacturer", "serialNumber"})
_ORDER_FIELDS: Final = frozenset({"orderId", "orderUpdateId", "nodes", "edges"})
_NODE_FIELDS: Final = frozenset({"nodeId", "sequenceId", "released", "actions"})
_EDGE_FIELDS: Final = frozenset({"edgeId", "sequenceId", "released", "actions"})
_ACTION_FIELDS: Final = frozenset({"actionId", "actionType", "blockingType"})
_POSITION_FIELDS: Final = frozenset({"x", "y", "mapId"})
# The optional fields of the 3.0 order schema: any of these that the vehicle does not
# take is refused; fields the schema does not know (an older version's) are ignored.
_OPTIONAL: Final = {
    "order": ("orderDescription",),
    "order.nodes": ("nodeDescriptor", "nodePosition"),
    "order.nodes.nodePosition": ("theta", "allowedDeviationXY", "allowedDeviationTheta"),
    "order.nodes.actions": ("actionDescriptor", "actionParameters", "retriable"),
    "order.edges": (
        "edgeDescriptor",
        "maximumSpeed",
        "maximumMobileRobotHeight",
        "minimumLoadHandlingDeviceHeight",
        "orientation",
        "orientationType",
        "direction",
        "reachOrientationBeforeEntering",
        "maximumRotationSpeed",
        "maxRotationSpeed",
        "trajectory",
        "length",
        "corridor",
    ),
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


@dataclass(frozen=True, slots=True)
class ParsedOrder:
    """An order message that passed :func:`parse_order`.

    Attributes:
        order_id: its ``orderId``.
        update_id: its ``orderUpdateId``.
        nodes: its nodes by ``sequenceId``.
        edges: its edges by ``sequenceId``.
        actions: its node actions, in the order of nodes and of each node's ``actions``.
        content: what it says beyond its header, canonical (tells a resent message from
            a different one with the same ids).
    """

    order_id: str
    update_id: int
    nodes: tuple[OrderNode, ...]
    edges: tuple[OrderEdge, ...]
    actions: tuple[OrderAction, ...]
    content: str

    @property
    def ref(self) -> tuple[tuple[str, str], ...]:
        """The error references that name this message."""
        return (("orderId", self.order_id), ("orderUpdateId", str(self.update_id)))


def _reject(error_type: str, text: str, ref: tuple[tuple[str, str], ...], **kw: str) -> None:
    raise OrderRejected(VdaError(error_type, text, ref, **kw))


def _unsupported(order: Mapping[str, Any]) -> list[str]:
    """The optional fields present in ``order`` that the vehicle does not take."""
    found: set[str] = set()

    def look(where: str, item: Mapping[str, Any]) -> None:
        for key in _OPTIONAL.get(where, ()):
            if key not in item:
                continue
            name = f"{where}.{key}"
            if key == "retriable" and item[key] is False:
                continue  # the default, spelt out
            if name not in OPTIONAL_PARAMETERS:
                found.add(name)

    look("order", order)
    for node in order["nodes"]:
        look("order.nodes", node)
        if "nodePosition" in node:
            look("order.nodes.nodePosition", node["nodePosition"])
        for action in node["actions"]:
            look("order.nodes.actions", action)
    for edge in order["edges"]:
        look("order.edges", edge)
    return sorted(found)


def _structure(order: Mapping[str, Any], ref: tuple[tuple[str, str], ...]) -> None:
    """Sequence ids, edge count, base before horizon (``VALIDATION_FAILURE``)."""
    nodes = sorted(order["nodes"], key=lambda n: n["sequenceId"])
    edges = sorted(order["edges"], key=lambda e: e["sequenceId"])
    if not nodes:
        _reject(VALIDATION_FAILURE, "an order needs at least one node", ref)
    if len(edges) != len(nodes) - 1:
        _reject(
            VALIDATION_FAILURE,
            f"{len(nodes)} nodes need {len(nodes) - 1} edges, got {len(edges)}",
            ref,
        )
    first = nodes[0]["sequenceId"]
    for i, node in enumerate(nodes):
        if node["sequenceId"] != first + 2 * i or node["sequenceId"] % 2:
            _reject(
                VALIDATION_FAILURE,
                "node sequenceIds must be even and step by 2 (edges take the odd ones)",
                (*ref, ("nodeId", node["nodeId"])),
            )
    for i, edge in enumerate(edges):
        if edge["sequenceId"] != first + 2 * i + 1:
            _reject(
                VALIDATION_FAILURE,
                "each edge's sequenceId must lie between its two nodes'",
                (*ref, ("edgeId", edge["edgeId"])),
            )
    if not nodes[0]["released"]:
        _reject(VALIDATION_FAILURE, "the first node must be released", ref)
    for prev, node, edge in zip(nodes, nodes[1:], edges, strict=False):
        if (node["released"] and not prev["released"]) or edge["released"] != node["released"]:
            _reject(
                VALIDATION_FAILURE,
                "released nodes and edges must come first (the base), then the horizon",
                (*ref, ("nodeId", node["nodeId"])),
            )
    ids = [a["actionId"] for n in nodes for a in n["actions"]]
    ids += [a["actionId"] for e in edges for a in e["actions"]]
    if len(ids) != len(set(ids)):
        _reject(VALIDATION_FAILURE, "every action of an order needs its own actionId", ref)


def _route(order: Mapping[str, Any], layout: Layout, ref: tuple[tuple[str, str], ...]) -> None:
    """Maps, nodes and edges on the layout (``UNKNOWN_MAP_ID``, ``NO_ROUTE_TO_TARGET``)."""
    nodes = sorted(order["nodes"], key=lambda n: n["sequenceId"])
    edges = sorted(order["edges"], key=lambda e: e["sequenceId"])
    for node in nodes:
        position = node.get("nodePosition")
        if position is not None and position["mapId"] != layout.name:
            _reject(
                UNKNOWN_MAP_ID,
                f"node {node['nodeId']!r} is on map {position['mapId']!r}; the vehicle "
                f"knows {layout.name!r}",
                (*ref, ("nodeId", node["nodeId"]), ("mapId", str(position["mapId"]))),
            )
    for node in nodes:
        node_ref = (*ref, ("nodeId", node["nodeId"]))
        point = layout.points.get(node["nodeId"])
        if point is None:
            _reject(NO_ROUTE_TO_TARGET, f"node {node['nodeId']!r} is not on the layout", node_ref)
            continue
        position = node.get("nodePosition")
        if (
            position is not None
            and math.dist((position["x"], position["y"]), (point.x, point.y))
            > NODE_POSITION_TOLERANCE_M
        ):
            _reject(
                NO_ROUTE_TO_TARGET,
                f"node {point.id!r} is at ({point.x}, {point.y}) on the layout, not at "
                f"({position['x']}, {position['y']})",
                node_ref,
            )
    for a, b, edge in zip(nodes, nodes[1:], edges, strict=False):
        if not edge_fits(layout, a["nodeId"], b["nodeId"], edge["edgeId"]):
            _reject(
                NO_ROUTE_TO_TARGET,
                f"edge {edge['edgeId']!r} is no segment drivable from {a['nodeId']!r} to "
                f"{b['nodeId']!r}",
                (*ref, ("edgeId", edge["edgeId"])),
            )


def _actions(
    order: Mapping[str, Any], layout: Layout, ref: tuple[tuple[str, str], ...]
) -> list[OrderAction]:
    """The node actions, each one the vehicle can carry out where it is
    (``INVALID_ORDER_ACTION``)."""
    for edge in order["edges"]:
        if edge["actions"]:
            action = edge["actions"][0]
            _reject(
                INVALID_ORDER_ACTION,
                f"the vehicle carries out no actions on edges ({action['actionType']!r})",
                (*ref, ("edgeId", edge["edgeId"]), ("actionId", action["actionId"])),
            )
    out = []
    for node in sorted(order["nodes"], key=lambda n: n["sequenceId"]):
        for raw in node["actions"]:
            action = OrderAction(
                str(raw["actionId"]),
                str(raw["actionType"]),
                str(raw["blockingType"]),
                str(node["nodeId"]),
                int(node["sequenceId"]),
                tuple((str(p["key"]), p["value"]) for p in raw.get("actionParameters", [])),
            )
            spec = CATALOGUE.get(action.action_type)
            problem = None
            if spec is None or "NODE" not in spec.scopes:
                problem = f"the vehicle carries out no {action.action_type!r} on nodes"
            elif action.blocking_type not in spec.blocking_types:
                problem = (
                    f"{action.action_type} takes blockingType "
                    f"{' or '.join(spec.blocking_types)}, not {action.blocking_type!r}"
                )
            else:
                problem = node_action_problem(layout, action)
            if problem is not None:
                _reject(
                    INVALID_ORDER_ACTION,
                    problem,
                    (*ref, ("nodeId", action.node_id), ("actionId", action.action_id)),
                )
            out.append(action)
    return out


def parse_order(
    message: Any, layout: Layout, *, manufacturer: str, serial_number: str
) -> ParsedOrder:
    """Check an ``order`` message as a whole (see the module doc).

    Raises:
        OrderRejected: with the error to report; the first problem found wins.
    """
    problems = schema_errors("order", message)
    if problems:
        named = message.get("orderId") if isinstance(message, dict) else None
        _reject(
            VALIDATION_FAILURE,
            "; ".join(problems),
            (("orderId", named),) if isinstance(named, str) else (),
        )
    order_id = str(message["orderId"])
    update_id = int(message["orderUpdateId"])
    ref = (("orderId", order_id), ("orderUpdateId", str(update_id)))
    if (message["manufacturer"], message["serialNumber"]) != (manufacturer, serial_number):
        _reject(VALIDATION_FAILURE, "the order is for another vehicle", ref)
    _structure(message, ref)
    unsupported = _unsupported(message)
    if unsupported:
        _reject(
            UNSUPPORTED_PARAMETER,
            f"the vehicle does not take {', '.join(unsupported)} (see the factsheet's "
            "optionalParameters)",
            (*ref, *(("parameter", name) for name in unsupported)),
            level=CRITICAL,
        )
    _route(message, layout, ref)
    actions = _actions(message, layout, ref)
    nodes = sorted(message["nodes"], key=lambda n: n["sequenceId"])
    edges = sorted(message["edges"], key=lambda e: e["sequenceId"])
    content = json.dumps(
        {k: v for k, v in message.items() if k not in _HEADER}, sort_keys=True, default=str
    )
    return ParsedOrder(
        order_id,
        update_id,
        tuple(OrderNode(n["nodeId"], n["sequenceId"], n["released"]) for n in nodes),
        tuple(OrderEdge(e["edgeId"], e["sequenceId"], e["released"]) for e in edges),
        tuple(actions),
        content,
    )


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
                _reject(
                    OUTDATED_ORDER_UPDATE,
                    f"orderUpdateId {order.update_id} is older than {self.order_update_id}",
                    ref,
                )
            if self.cancelled:
                _reject(
                    ORDER_UPDATE_FOLLOWING_CANCEL, f"order {order.order_id!r} was cancelled", ref
                )
            if order.update_id == self.order_update_id:
                if order.content == self._content:
                    return "duplicate"
                _reject(
                    SAME_ORDER_UPDATE_ID,
                    f"orderUpdateId {order.update_id} came before with other content",
                    ref,
                )
            self._update(order)
            return "updated"
        if self.active:
            _reject(
                OTHER_ORDER_ACTIVE,
                f"order {self.order_id!r} is still active: cancel it first",
                ref,
            )
        first = order.nodes[0]
        if first.node_id != self.last_node_id or not at_rest:
            _reject(
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
            _reject(
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
