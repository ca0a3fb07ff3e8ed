"""An ``order`` message checked as a whole, sans I/O: what the vehicle takes, or the 3.0 error.

:func:`parse_order` checks an ``order`` message in the order VDA 5050 3.0 asks (Figure 8
and section 6.1.4): the schema and the header (``VALIDATION_FAILURE``), the optional
fields (``UNSUPPORTED_PARAMETER``, :data:`OPTIONAL_PARAMETERS` lists those the vehicle
takes), the maps (``UNKNOWN_MAP_ID``), the route on the layout (``NO_ROUTE_TO_TARGET``)
and the actions (``INVALID_ORDER_ACTION``). What passes is a :class:`ParsedOrder`; what
does not raises :class:`OrderRejected` with the error entry to report. Whether a parsed
order is taken is :class:`agv_app.vda5050.order.OrderBook`'s business.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final

from agv_app.layout.graph import Layout
from agv_app.vda5050.actions import CATALOGUE, OrderAction
from agv_app.vda5050.handling import node_action_problem
from agv_app.vda5050.mapping import edge_fits
from agv_app.vda5050.reports import (
    CRITICAL,
    INVALID_ORDER_ACTION,
    NO_ROUTE_TO_TARGET,
    UNKNOWN_MAP_ID,
    UNSUPPORTED_PARAMETER,
    VALIDATION_FAILURE,
    VdaError,
)
from agv_app.vda5050.validation import schema_errors

__all__ = [
    "NODE_POSITION_TOLERANCE_M",
    "OPTIONAL_PARAMETERS",
    "OrderEdge",
    "OrderNode",
    "OrderRejected",
    "ParsedOrder",
    "parse_order",
    "reject",
]

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


def reject(error_type: str, text: str, ref: tuple[tuple[str, str], ...], **kw: str) -> None:
    """Raise :class:`OrderRejected` with the error entry of ``error_type``, ``text`` and
    the references ``ref`` (``kw``: the entry's other fields, such as its level)."""
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
        reject(VALIDATION_FAILURE, "an order needs at least one node", ref)
    if len(edges) != len(nodes) - 1:
        reject(
            VALIDATION_FAILURE,
            f"{len(nodes)} nodes need {len(nodes) - 1} edges, got {len(edges)}",
            ref,
        )
    first = nodes[0]["sequenceId"]
    for i, node in enumerate(nodes):
        if node["sequenceId"] != first + 2 * i or node["sequenceId"] % 2:
            reject(
                VALIDATION_FAILURE,
                "node sequenceIds must be even and step by 2 (edges take the odd ones)",
                (*ref, ("nodeId", node["nodeId"])),
            )
    for i, edge in enumerate(edges):
        if edge["sequenceId"] != first + 2 * i + 1:
            reject(
                VALIDATION_FAILURE,
                "each edge's sequenceId must lie between its two nodes'",
                (*ref, ("edgeId", edge["edgeId"])),
            )
    if not nodes[0]["released"]:
        reject(VALIDATION_FAILURE, "the first node must be released", ref)
    for prev, node, edge in zip(nodes, nodes[1:], edges, strict=False):
        if (node["released"] and not prev["released"]) or edge["released"] != node["released"]:
            reject(
                VALIDATION_FAILURE,
                "released nodes and edges must come first (the base), then the horizon",
                (*ref, ("nodeId", node["nodeId"])),
            )
    ids = [a["actionId"] for n in nodes for a in n["actions"]]
    ids += [a["actionId"] for e in edges for a in e["actions"]]
    if len(ids) != len(set(ids)):
        reject(VALIDATION_FAILURE, "every action of an order needs its own actionId", ref)


def _route(order: Mapping[str, Any], layout: Layout, ref: tuple[tuple[str, str], ...]) -> None:
    """Maps, nodes and edges on the layout (``UNKNOWN_MAP_ID``, ``NO_ROUTE_TO_TARGET``)."""
    nodes = sorted(order["nodes"], key=lambda n: n["sequenceId"])
    edges = sorted(order["edges"], key=lambda e: e["sequenceId"])
    for node in nodes:
        position = node.get("nodePosition")
        if position is not None and position["mapId"] != layout.name:
            reject(
                UNKNOWN_MAP_ID,
                f"node {node['nodeId']!r} is on map {position['mapId']!r}; the vehicle "
                f"knows {layout.name!r}",
                (*ref, ("nodeId", node["nodeId"]), ("mapId", str(position["mapId"]))),
            )
    for node in nodes:
        node_ref = (*ref, ("nodeId", node["nodeId"]))
        point = layout.points.get(node["nodeId"])
        if point is None:
            reject(NO_ROUTE_TO_TARGET, f"node {node['nodeId']!r} is not on the layout", node_ref)
            continue
        position = node.get("nodePosition")
        if (
            position is not None
            and math.dist((position["x"], position["y"]), (point.x, point.y))
            > NODE_POSITION_TOLERANCE_M
        ):
            reject(
                NO_ROUTE_TO_TARGET,
                f"node {point.id!r} is at ({point.x}, {point.y}) on the layout, not at "
                f"({position['x']}, {position['y']})",
                node_ref,
            )
    for a, b, edge in zip(nodes, nodes[1:], edges, strict=False):
        if not edge_fits(layout, a["nodeId"], b["nodeId"], edge["edgeId"]):
            reject(
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
            reject(
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
                reject(
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
        reject(
            VALIDATION_FAILURE,
            "; ".join(problems),
            (("orderId", named),) if isinstance(named, str) else (),
        )
    order_id = str(message["orderId"])
    update_id = int(message["orderUpdateId"])
    ref = (("orderId", order_id), ("orderUpdateId", str(update_id)))
    if (message["manufacturer"], message["serialNumber"]) != (manufacturer, serial_number):
        reject(VALIDATION_FAILURE, "the order is for another vehicle", ref)
    _structure(message, ref)
    unsupported = _unsupported(message)
    if unsupported:
        reject(
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
