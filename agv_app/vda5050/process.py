"""What an AGV process needs to speak VDA 5050: its controller class, its link, its bridge.

A vehicle process (``agv_app.fleet.agv_process``) joins with the credential options
(``--pki DIR``, or ``--insecure`` and a secret): :func:`vehicle_link` turns those and
``--vda5050 mqtts://HOST:PORT`` into the vehicle's link to the broker, with the same
certificate it holds on the mesh (role ``agv``, its id the serial number), or a plain
``mqtt://`` link on loopback with ``--insecure``. Call it, and
:func:`~agv_app.vda5050.link.check_broker`, before anything starts: a bad address, a
missing certificate or a broker that refuses it is then a one-line refusal and exit
status 2.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from agv_app.vda5050.bridge import BridgeCounters, run_bridge
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.link import MqttLink, mqtt_link
from agv_app.vda5050.topics import MANUFACTURER, VehicleTopics, parse_broker_url
from agv_app.vda5050.vehicle import OrderAgv
from agv_app.vehicle.controller import AgvController
from objectplaces.security import Credentials

__all__ = ["VEHICLE_ROLES", "bridge_for", "vehicle_class", "vehicle_link"]

VEHICLE_ROLES = ("agv",)
"""The certificate roles a vehicle's VDA 5050 client may have."""


def vehicle_class(broker_url: str | None) -> Callable[..., AgvController]:
    """The AGV component to build: order-driven with a broker, the plain one without."""
    if broker_url is None:
        return AgvController
    parse_broker_url(broker_url)  # refuse a bad address before anything starts
    return functools.partial(OrderAgv, manufacturer=MANUFACTURER)


def vehicle_link(broker_url: str, credentials: Credentials, node_id: str) -> MqttLink:
    """The link of vehicle ``node_id`` to the broker at ``broker_url``.

    Raises:
        ValueError: a malformed address.
        LocalProtocolError: ``mqtts://`` without a certificate, ``mqtt://`` without
            ``--insecure`` or off loopback.
        CredentialError: the certificate names another id, or is not a vehicle's.
    """
    return mqtt_link(
        broker_url,
        tls=credentials.tls,
        insecure=credentials.insecure,
        client_id=node_id,
        roles=VEHICLE_ROLES,
    )


async def bridge_for(
    agv: AgvController, link: MqttLink, counters: BridgeCounters | None = None
) -> Any:
    """Run the VDA 5050 bridge of ``agv`` (built by :func:`vehicle_class`) until cancelled.

    Raises:
        TypeError: ``agv`` does not follow orders.
        CredentialError: the link's certificate is not the vehicle's.
    """
    if not isinstance(agv, OrderAgv):
        raise TypeError("the VDA 5050 bridge needs an OrderAgv (see vehicle_class)")
    endpoint = VdaEndpoint(agv, VehicleTopics(MANUFACTURER, agv.node_id))
    await run_bridge(endpoint, link, counters=counters)
