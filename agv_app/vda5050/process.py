"""What an AGV process needs to speak VDA 5050: its controller class and its bridge."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from agv_app.vda5050.bridge import BridgeCounters, run_bridge
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.topics import MANUFACTURER, VehicleTopics, parse_broker_url
from agv_app.vda5050.vehicle import OrderAgv
from agv_app.vehicle.controller import AgvController

__all__ = ["bridge_for", "vehicle_class"]


def vehicle_class(broker_url: str | None) -> Callable[..., AgvController]:
    """The AGV component to build: order-driven with a broker, the plain one without."""
    if broker_url is None:
        return AgvController
    parse_broker_url(broker_url)  # refuse a bad address before anything starts
    return functools.partial(OrderAgv, manufacturer=MANUFACTURER)


async def bridge_for(
    agv: AgvController, broker_url: str, counters: BridgeCounters | None = None
) -> Any:
    """Run the VDA 5050 bridge of ``agv`` (built by :func:`vehicle_class`) until cancelled.

    Raises:
        TypeError: ``agv`` does not follow orders.
    """
    if not isinstance(agv, OrderAgv):
        raise TypeError("the VDA 5050 bridge needs an OrderAgv (see vehicle_class)")
    endpoint = VdaEndpoint(agv, VehicleTopics(MANUFACTURER, agv.node_id))
    await run_bridge(endpoint, parse_broker_url(broker_url), counters=counters)
