"""VDA 5050 3.0 over MQTT: every AGV speaks the industry's AGV interface (docs/vda5050.md)."""

from __future__ import annotations

from agv_app.vda5050.bridge import BridgeCounters, run_bridge
from agv_app.vda5050.broker import LocalBroker, demo_broker
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.order import OrderBook, OrderRejected, VdaError
from agv_app.vda5050.topics import BrokerAddress, VehicleTopics, parse_broker_url
from agv_app.vda5050.vehicle import OrderAgv

__all__ = [
    "BridgeCounters",
    "BrokerAddress",
    "LocalBroker",
    "OrderAgv",
    "OrderBook",
    "OrderRejected",
    "VdaEndpoint",
    "VdaError",
    "VehicleTopics",
    "demo_broker",
    "parse_broker_url",
    "run_bridge",
]
