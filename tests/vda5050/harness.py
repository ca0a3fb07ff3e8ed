"""A VDA 5050 vehicle on the simulated network (virtual clock), and order builders."""

from __future__ import annotations

import json
from collections.abc import Callable
from itertools import pairwise
from typing import Any

from agv_app.fleet.parking import ParkingPlan, home_heading
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.mapping import vda_edge_id
from agv_app.vda5050.messages import timestamp
from agv_app.vda5050.topics import MANUFACTURER, PROTOCOL_VERSION, VehicleTopics
from agv_app.vda5050.vehicle import OrderAgv
from agv_app.vehicle.controller import AgvConfig
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces.sim import SimulatedNetwork

DT = 0.1


def header(serial: str, header_id: int = 0) -> dict[str, Any]:
    """The header of a message to vehicle ``serial``."""
    return {
        "headerId": header_id,
        "timestamp": timestamp(),
        "version": PROTOCOL_VERSION,
        "manufacturer": MANUFACTURER,
        "serialNumber": serial,
    }


def make_order(
    layout: Layout,
    serial: str,
    points: list[str],
    *,
    order_id: str = "order-1",
    update_id: int = 0,
    released: int | None = None,
    first_sequence: int = 0,
    actions: dict[int, list[dict[str, Any]]] | None = None,
) -> dict[str, Any]:
    """An order along ``points``; the first ``released`` nodes are the base (all: None);
    ``actions`` by index of the node they are on."""
    base = len(points) if released is None else released
    nodes = [
        {
            "nodeId": p,
            "sequenceId": first_sequence + 2 * i,
            "released": i < base,
            "actions": (actions or {}).get(i, []),
        }
        for i, p in enumerate(points)
    ]
    edges: list[dict[str, Any]] = [
        {
            "edgeId": vda_edge_id(layout, a, b),
            "sequenceId": first_sequence + 2 * i + 1,
            "released": i + 1 < base,
            "actions": [],
        }
        for i, (a, b) in enumerate(pairwise(points))
    ]
    return {
        **header(serial),
        "orderId": order_id,
        "orderUpdateId": update_id,
        "nodes": nodes,
        "edges": edges,
    }


def action(
    action_id: str, action_type: str, blocking: str = "HARD", **parameters: Any
) -> dict[str, Any]:
    """A node action."""
    out: dict[str, Any] = {
        "actionId": action_id,
        "actionType": action_type,
        "blockingType": blocking,
    }
    if parameters:
        out["actionParameters"] = [{"key": k, "value": v} for k, v in parameters.items()]
    return out


def instant(serial: str, *actions: tuple[str, str]) -> dict[str, Any]:
    """An instantActions message with ``(actionId, actionType)`` pairs."""
    return {
        **header(serial),
        "actions": [{"actionId": i, "actionType": t, "blockingType": "NONE"} for i, t in actions],
    }


class OneVehicle:
    """One order-driven AGV (``node_id``) at its parking spot on the demo warehouse,
    virtual time."""

    def __init__(self, seed: int = 1, *, node_id: str = "agv-01") -> None:
        self.layout = demo_warehouse()
        spec = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
        self.home = ParkingPlan(self.layout, spec, 1, rest_elsewhere=False).homes[0]
        self.net = SimulatedNetwork(seed, property_interval=1.0, failure_timeout=3.0)
        node = self.net.add_node(node_id)
        self.agv = OrderAgv(
            node,
            self.layout,
            spec,
            self.home,
            heading_rad=home_heading(self.layout, self.home),
            config=AgvConfig(),
            manufacturer=MANUFACTURER,
        )
        self.endpoint = VdaEndpoint(self.agv, VehicleTopics(MANUFACTURER, node_id))

    def run(self, seconds: float) -> None:
        """Step the network and the AGV for ``seconds`` of virtual time."""
        for _ in range(round(seconds / DT)):
            self.net.run_for(DT)
            self.agv.step(DT)

    def path(self, dest: str) -> list[str]:
        """The shortest path from the AGV's home to ``dest``."""
        return list(self.layout.shortest_path(self.home, dest))

    def state(self) -> dict[str, Any]:
        """The state the endpoint would publish now."""
        return self.endpoint.state_now()

    def send(self, subtopic: str, message: Any) -> None:
        """Hand the endpoint a message, as the bridge does."""
        self.endpoint.handle(subtopic, json.dumps(message).encode(), now=self.net.now)

    def run_until(self, what: Callable[[], bool], *, within: float) -> float:
        """Step until ``what()`` holds (virtual seconds, at most ``within``); the time."""
        for _ in range(round(within / DT)):
            if what():
                return self.net.now
            self.run(DT)
        raise AssertionError(f"not within {within} virtual seconds")
