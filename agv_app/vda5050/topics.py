"""VDA 5050 3.0 topic names and the broker address ``mqtt://HOST:PORT``.

Every message of one vehicle travels under
``<interfaceName>/<majorVersion>/<manufacturer>/<serialNumber>/<subtopic>``; the
interface name is ``uagv`` and the major version ``v3``.
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

SUBTOPICS = ("order", "instantActions", "state", "visualization", "connection", "factsheet")
"""The subtopics the bridge uses (``zoneSet`` and ``responses`` are not supported)."""

_DEFAULT_PORT = 1883


@dataclass(frozen=True, slots=True)
class BrokerAddress:
    """Where the MQTT broker listens."""

    host: str
    port: int

    @property
    def url(self) -> str:
        """The address as ``mqtt://HOST:PORT``."""
        return f"mqtt://{self.host}:{self.port}"


def parse_broker_url(url: str) -> BrokerAddress:
    """Parse ``mqtt://HOST[:PORT]`` (the port defaults to 1883).

    Raises:
        ValueError: another scheme, no host, or a port out of range.
    """
    parts = urlsplit(url)
    if parts.scheme != "mqtt":
        raise ValueError(f"the broker address must look like mqtt://HOST:PORT, got {url!r}")
    try:
        port = parts.port
    except ValueError as exc:
        raise ValueError(f"bad port in broker address {url!r}") from exc
    if not parts.hostname:
        raise ValueError(f"no host in broker address {url!r}")
    return BrokerAddress(parts.hostname, _DEFAULT_PORT if port is None else port)


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
