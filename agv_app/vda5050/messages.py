"""The VDA 5050 messages a vehicle sends: header, ``state``, ``visualization``,
``connection`` and ``factsheet``, built from an :class:`~agv_app.vda5050.vehicle.OrderAgv`.
"""

from __future__ import annotations

import datetime as dt
import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from agv_app.vda5050.order import VdaError
from agv_app.vda5050.topics import PROTOCOL_VERSION, VehicleTopics
from agv_app.vda5050.vehicle import OrderAgv

__all__ = [
    "INSTANT_ACTIONS",
    "SERIES_NAME",
    "ActionState",
    "Headers",
    "connection_message",
    "factsheet_message",
    "state_message",
    "timestamp",
    "visualization_message",
]

SERIES_NAME = "ObjectPlaces demo AGV"
"""The vehicles' ``seriesName`` in the factsheet."""

INSTANT_ACTIONS = ("cancelOrder", "startPause", "stopPause", "factsheetRequest", "stateRequest")
"""The instant actions the vehicle carries out."""


def timestamp(now: dt.datetime | None = None) -> str:
    """ISO 8601 in UTC with milliseconds, as the spec writes it: ``2026-11-23T17:33:36.123Z``."""
    t = now or dt.datetime.now(dt.UTC)
    return t.astimezone(dt.UTC).strftime("%Y-%m-%dT%H:%M:%S.") + f"{t.microsecond // 1000:03d}Z"


class Headers:
    """The header fields of one vehicle's messages; ``headerId`` counts per topic."""

    def __init__(self, topics: VehicleTopics) -> None:
        self.topics = topics
        self._next: defaultdict[str, int] = defaultdict(int)

    def last(self, subtopic: str) -> int:
        """The ``headerId`` of the last message on ``subtopic`` (-1: none yet)."""
        return self._next[subtopic] - 1

    def make(self, subtopic: str) -> dict[str, Any]:
        """A fresh header for the next message on ``subtopic``."""
        header_id = self._next[subtopic]
        self._next[subtopic] = header_id + 1
        return {
            "headerId": header_id,
            "timestamp": timestamp(),
            "version": PROTOCOL_VERSION,
            "manufacturer": self.topics.manufacturer,
            "serialNumber": self.topics.serial_number,
        }


@dataclass(frozen=True, slots=True)
class ActionState:
    """An instant action as the state reports it."""

    action_id: str
    action_type: str
    status: str
    result: str = ""

    def to_json(self) -> dict[str, Any]:
        """The ``actionState`` object."""
        out: dict[str, Any] = {
            "actionId": self.action_id,
            "actionType": self.action_type,
            "actionStatus": self.status,
        }
        if self.result:
            out["actionResult"] = self.result
        return out


def _position(agv: OrderAgv) -> dict[str, Any]:
    pose = agv.vehicle.pose()
    theta = math.remainder(pose.heading_rad, math.tau)
    return {
        "x": round(pose.x, 4),
        "y": round(pose.y, 4),
        "theta": round(max(-math.pi, min(math.pi, theta)), 5),
        "mapId": agv.layout.name,
        "localized": True,
    }


def _velocity(agv: OrderAgv) -> dict[str, float]:
    return {"vx": round(agv.vehicle.speed, 4), "vy": 0.0, "omega": 0.0}


def state_message(
    agv: OrderAgv,
    headers: Headers,
    *,
    errors: Sequence[VdaError],
    instant_actions: Sequence[ActionState],
) -> dict[str, Any]:
    """The vehicle's ``state`` now (takes the next ``state`` headerId)."""
    book = agv.book_of_orders
    operating = "INTERVENED" if agv.failed else "AUTOMATIC"
    return {
        **headers.make("state"),
        "orderId": book.order_id,
        "orderUpdateId": book.order_update_id,
        "lastNodeId": book.last_node_id,
        "lastNodeSequenceId": book.last_node_sequence_id,
        "nodeStates": [n.to_json() for n in book.nodes],
        "edgeStates": [e.to_json() for e in book.edges],
        "mobileRobotPosition": _position(agv),
        "velocity": _velocity(agv),
        "driving": agv.driving,
        "paused": agv.paused,
        "newBaseRequest": book.waiting_for_update(),
        "actionStates": [],
        "instantActionStates": [a.to_json() for a in instant_actions],
        "powerSupply": {"stateOfCharge": 80.0, "charging": False},
        "operatingMode": operating,
        "errors": [e.to_json() for e in errors],
        "safetyState": {"activeEmergencyStop": "NONE", "fieldViolation": False},
    }


def visualization_message(agv: OrderAgv, headers: Headers) -> dict[str, Any]:
    """The vehicle's ``visualization`` now: position and velocity, tied to the last state."""
    return {
        **headers.make("visualization"),
        "referenceStateHeaderId": max(0, headers.last("state")),
        "mobileRobotPosition": _position(agv),
        "velocity": _velocity(agv),
    }


def connection_message(headers: Headers, connection_state: str) -> dict[str, Any]:
    """A ``connection`` message: ``ONLINE``, ``OFFLINE`` or ``CONNECTION_BROKEN``."""
    return {**headers.make("connection"), "connectionState": connection_state}


def factsheet_message(
    agv: OrderAgv, headers: Headers, *, state_interval_s: float
) -> dict[str, Any]:
    """The vehicle's ``factsheet``: type, size, limits, supported actions."""
    spec = agv.spec
    return {
        **headers.make("factsheet"),
        "typeSpecification": {
            "seriesName": SERIES_NAME,
            "seriesDescription": "A simulated carrier; traffic control by ObjectPlaces groups",
            "mobileRobotKinematics": "DIFFERENTIAL",
            "mobileRobotClass": "CARRIER",
            "maximumLoadMass": 0.0,
            "localizationTypes": ["NATURAL"],
            "navigationTypes": ["VIRTUAL_LINE_GUIDED"],
        },
        "physicalParameters": {
            "minimumSpeed": 0.0,
            "maximumSpeed": spec.max_speed_m_s,
            "maximumAcceleration": spec.max_accel_m_s2,
            "maximumDeceleration": spec.max_accel_m_s2,
            "minimumHeight": 0.0,
            "maximumHeight": 0.0,
            "width": spec.width_m,
            "length": spec.length_m,
        },
        "protocolLimits": {
            "maximumStringLengths": {},
            "maximumArrayLengths": {"node.actions": 0, "edge.actions": 0},
            "timing": {
                "minimumOrderInterval": 0.0,
                "minimumStateInterval": state_interval_s,
            },
        },
        "protocolFeatures": {
            "optionalParameters": [],
            "mobileRobotActions": [
                {
                    "actionType": name,
                    "actionScopes": ["INSTANT"],
                    "pauseAllowed": False,
                    "cancelAllowed": False,
                }
                for name in INSTANT_ACTIONS
            ],
        },
        "mobileRobotGeometry": {},
        "loadSpecification": {},
    }
