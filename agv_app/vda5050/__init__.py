"""VDA 5050 3.0 over MQTT: every AGV speaks the industry's AGV interface (docs/vda5050.md)."""

from __future__ import annotations

from agv_app.vda5050.acl import access_list
from agv_app.vda5050.bridge import BridgeCounters, run_bridge
from agv_app.vda5050.broker import LocalBroker
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.link import (
    BrokerError,
    MqttLink,
    VdaCredentials,
    check_broker,
    mqtt_link,
    probe_broker,
)
from agv_app.vda5050.order import OrderBook, OrderRejected
from agv_app.vda5050.reports import VdaError
from agv_app.vda5050.topics import BrokerAddress, VehicleTopics, parse_broker_url
from agv_app.vda5050.vehicle import OrderAgv

__all__ = [
    "BridgeCounters",
    "BrokerAddress",
    "BrokerError",
    "LocalBroker",
    "MqttLink",
    "OrderAgv",
    "OrderBook",
    "OrderRejected",
    "VdaCredentials",
    "VdaEndpoint",
    "VdaError",
    "VehicleTopics",
    "access_list",
    "check_broker",
    "mqtt_link",
    "parse_broker_url",
    "probe_broker",
    "run_bridge",
]
