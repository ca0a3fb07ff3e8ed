"""VDA 5050 3.0 topic names and the broker address ``mqtts://HOST:PORT``.

Every message of one vehicle travels under
``<interfaceName>/<majorVersion>/<manufacturer>/<serialNumber>/<subtopic>``; the
interface name is ``uagv`` and the major version ``v3``. A vehicle's serial number is
its node id, which is also the id its certificate names: the broker's access list
(``agv_app.vda5050.acl``) gives each certificate the topics of that serial number.
"""

from __future__ import annotations

from dataclasses import dataclass
from urllib.parse import urlsplit

__all__ = [
    "INTERFACE",
    "MAJOR_VERSION",
    "MANUFACTURER",
    "PROTOCOL_VERSION",
    "SUBTOPICS",
    "TO_MASTER",
    "TO_VEHICLE",
    "BrokerAddress",
    "VehicleTopics",
    "fleet_filter",
    "parse_broker_url",
]

INTERFACE = "uagv"
"""The interface name every topic starts with."""

MAJOR_VERSION = "v3"
"""The major protocol version in the topics."""

PROTOCOL_VERSION = "3.0.0"
"""The ``version`` field of every message sent."""

MANUFACTURER = "ObjectPlaces"
"""The ``manufacturer`` of the fleet's vehicles."""

TO_VEHICLE = ("order", "instantActions")
"""The subtopics a master control writes and a vehicle reads."""

TO_MASTER = ("state", "visualization", "connection", "factsheet")
"""The subtopics a vehicle writes and a master control reads."""

SUBTOPICS = TO_VEHICLE + TO_MASTER
"""The subtopics the bridge uses (``zoneSet`` and ``responses`` are not supported)."""

_PORTS = {"mqtts": 8883, "mqtt": 1883}


@dataclass(frozen=True, slots=True)
class BrokerAddress:
    """Where the MQTT broker listens, and whether over TLS (``mqtts``, the default)."""

    host: str
    port: int
    tls: bool = True

    @property
    def url(self) -> str:
        """The address as ``mqtts://HOST:PORT`` (``mqtt://`` for a plain listener)."""
        scheme = "mqtts" if self.tls else "mqtt"
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{scheme}://{host}:{self.port}"


def parse_broker_url(url: str) -> BrokerAddress:
    """Parse ``mqtts://HOST[:PORT]`` (TLS, port 8883 by default) or ``mqtt://HOST[:PORT]``
    (plain, port 1883 by default; who may use it is ``agv_app.vda5050.link``'s to say).

    Raises:
        ValueError: another scheme, no host, or a port out of range.
    """
    parts = urlsplit(url)
    if parts.scheme not in _PORTS:
        raise ValueError(f"the broker address must look like mqtts://HOST:PORT, got {url!r}")
    try:
        port = parts.port
    except ValueError as exc:
        raise ValueError(f"bad port in broker address {url!r}") from exc
    if not parts.hostname:
        raise ValueError(f"no host in broker address {url!r}")
    return BrokerAddress(
        parts.hostname,
        _PORTS[parts.scheme] if port is None else port,
        tls=parts.scheme == "mqtts",
    )


@dataclass(frozen=True, slots=True)
class VehicleTopics:
    """The topics of one vehicle.

    Attributes:
        manufacturer: the vehicle's manufacturer.
        serial_number: its serial number (the AGV's node id).
    """

    manufacturer: str
    serial_number: str

    def __post_init__(self) -> None:
        for value in (self.manufacturer, self.serial_number):
            if not value or any(c in value for c in "/+#"):
                raise ValueError(f"{value!r} cannot be a topic level")

    @property
    def prefix(self) -> str:
        """``uagv/v3/<manufacturer>/<serialNumber>``."""
        return f"{INTERFACE}/{MAJOR_VERSION}/{self.manufacturer}/{self.serial_number}"

    def topic(self, subtopic: str) -> str:
        """The full topic of ``subtopic`` (one of :data:`SUBTOPICS`)."""
        if subtopic not in SUBTOPICS:
            raise ValueError(f"unknown subtopic {subtopic!r}")
        return f"{self.prefix}/{subtopic}"


def fleet_filter(subtopic: str = "#") -> str:
    """A subscription filter for every vehicle of every manufacturer."""
    return f"{INTERFACE}/{MAJOR_VERSION}/+/+/{subtopic}"
