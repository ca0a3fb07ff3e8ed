"""Watches a fleet's VDA 5050 traffic on the broker, for the dashboard's status.

:class:`BrokerMonitor` subscribes to every vehicle's topics (``uagv/v3/+/+/#``) and
counts: is it connected to the broker, messages per second over the last few seconds,
and each vehicle's last ``connectionState``. Over TLS it connects as an observer (a
certificate of role ``control``: the broker lets it read every vehicle's topics and
write none, ``agv_app.vda5050.acl``).
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import json
import time
from collections.abc import Callable

import aiomqtt

from agv_app.vda5050.bridge import ConnectionTrouble, honour_cancellation
from agv_app.vda5050.link import MqttLink
from agv_app.vda5050.topics import fleet_filter

__all__ = ["MONITOR_ID", "MONITOR_ROLES", "BrokerMonitor"]

MONITOR_ID = "vda5050-monitor"
"""The broker monitor's id in a fleet PKI by default (role ``control``)."""

MONITOR_ROLES = ("control", "master")
"""The certificate roles a monitor may have: both may read every vehicle's topics."""

_WINDOW_S = 5.0


class BrokerMonitor:
    """Counts the fleet's VDA 5050 messages (run :meth:`run` as a task).

    Args:
        link: the broker, and the monitor's identity.
        clock: monotonic seconds.
        retry_s: wait before connecting again after the broker was lost.
    """

    def __init__(
        self,
        link: MqttLink,
        *,
        clock: Callable[[], float] = time.monotonic,
        retry_s: float = 1.0,
    ) -> None:
        self.link = link
        self.broker = link.broker
        self.clock = clock
        self.retry_s = retry_s
        self.connected = False
        self.messages = 0
        self.connection_states: dict[str, str] = {}
        """Each vehicle's last ``connectionState``, by serial number."""
        self._recent: collections.deque[float] = collections.deque()

    def messages_per_s(self) -> float:
        """Messages seen per second over the last five seconds."""
        now = self.clock()
        while self._recent and self._recent[0] < now - _WINDOW_S:
            self._recent.popleft()
        return len(self._recent) / _WINDOW_S

    def online(self) -> int:
        """How many vehicles last said ``ONLINE``."""
        return sum(s == "ONLINE" for s in self.connection_states.values())

    def seen(self, topic: str, payload: bytes) -> None:
        """Count one message (and note a vehicle's connection state)."""
        self.messages += 1
        self._recent.append(self.clock())
        if len(self._recent) > 100_000:
            self._recent.popleft()
        parts = topic.split("/")
        if len(parts) == 5 and parts[4] == "connection":
            with contextlib.suppress(ValueError, TypeError, AttributeError):
                state = json.loads(payload).get("connectionState")
                if isinstance(state, str):
                    self.connection_states[parts[3]] = state

    async def run(self) -> None:
        """Watch until cancelled, reconnecting after a lost broker."""
        trouble = ConnectionTrouble("VDA 5050 broker monitor")
        while True:
            try:
                async with self.link.client() as client:
                    self.connected = True
                    trouble.connected()
                    await client.subscribe(fleet_filter())
                    honour_cancellation()
                    async for message in client.messages:
                        payload = message.payload if isinstance(message.payload, bytes) else b""
                        self.seen(str(message.topic), payload)
            except aiomqtt.MqttError as error:
                await trouble.failed(self.link, error, connected=self.connected)
            finally:
                self.connected = False
            await asyncio.sleep(self.retry_s)

    def status(self) -> dict[str, float]:
        """The figures the dashboard shows, as ``vda5050_*`` metrics."""
        return {
            "vda5050_broker_connected": 1.0 if self.connected else 0.0,
            "vda5050_messages_per_s": self.messages_per_s(),
            "vda5050_messages": float(self.messages),
            "vda5050_vehicles_online": float(self.online()),
        }
