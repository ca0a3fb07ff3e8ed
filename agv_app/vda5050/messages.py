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

from agv_app.vda5050.actions import CATALOGUE
from agv_app.vda5050.charging import power_supply
from agv_app.vda5050.handling import LOAD_POSITION
from agv_app.vda5050.order import OPTIONAL_PARAMETERS
from agv_app.vda5050.reports import VdaError
from agv_app.vda5050.topics import PROTOCOL_VERSION, VehicleTopics
from agv_app.vda5050.vehicle import OrderAgv

__all__ = [
    "MAX_ERRORS_LISTED",
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

MAX_ERRORS_LISTED = 10
"""The most errors a state lists."""


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
    """An instant action as the state reports it (``instantActionStates``)."""

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
    now = agv.node.now()
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
        "loads": [load.to_json() for load in agv.handling.loads],
        "actionStates": book.actions.to_json(),
        "instantActionStates": [a.to_json() for a in instant_actions],
        "powerSupply": power_supply(agv.battery, now),
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
    agv: OrderAgv,
    headers: Headers,
    *,
    state_interval_s: float,
    min_state_interval_s: float,
    visualization_interval_s: float,
    max_instant_action_states: int,
) -> dict[str, Any]:
    """The vehicle's ``factsheet``: type, size, limits, supported features and actions."""
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
            # Only the limits there are: orders of any length are taken.
            "maximumArrayLengths": {
                "state.loads": 1,
                "state.instantActionStates": max_instant_action_states,
                "state.errors": MAX_ERRORS_LISTED,
            },
            "timing": {
                "minimumOrderInterval": 0.0,
                "minimumStateInterval": min_state_interval_s,
                "defaultStateInterval": state_interval_s,
                "visualizationInterval": visualization_interval_s,
            },
        },
        "protocolFeatures": {
            "optionalParameters": [
                {"parameter": name, "support": "SUPPORTED", "description": text}
                for name, text in OPTIONAL_PARAMETERS.items()
            ],
            "mobileRobotActions": [a.to_json() for a in CATALOGUE.values()],
        },
        "mobileRobotGeometry": {},
        "loadSpecification": {"loadPositions": [LOAD_POSITION]},
    }
