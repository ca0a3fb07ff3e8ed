"""A master control's view of the broker in tests: every message of every vehicle, timed.

It connects as the link says: over TLS with a master control's certificate (the broker
lets it read every vehicle's topics and send every vehicle orders and instant actions).
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime as dt
import itertools
import json
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from typing import Any

import aiomqtt

from agv_app.vda5050.link import MqttLink
from agv_app.vda5050.topics import MANUFACTURER, VehicleTopics, fleet_filter

_POLL_S = 0.05
_SEND_TIMEOUT_S = 30.0  # a PUBACK on a machine loaded far beyond its cores


@dataclass(frozen=True)
class Seen:
    """One message as the probe received it."""

    at: float
    serial: str
    subtopic: str
    message: Any


def sent_at(message: Any) -> float:
    """A message's own ``timestamp``, in seconds since the epoch."""
    stamp = dt.datetime.strptime(message["timestamp"], "%Y-%m-%dT%H:%M:%S.%fZ")
    return stamp.replace(tzinfo=dt.UTC).timestamp()


def state_gaps(seen: list[Seen]) -> list[float]:
    """Seconds between consecutive messages, by the timestamps the vehicle gave them
    (what it published when, whatever delayed the probe's own loop)."""
    times = [sent_at(s.message) for s in seen]
    return [b - a for a, b in itertools.pairwise(times)]


class Probe:
    """Collects messages; sends orders and instant actions."""

    def __init__(self, client: aiomqtt.Client) -> None:
        self.client = client
        self.seen: list[Seen] = []

    def of(self, serial: str, subtopic: str) -> list[Seen]:
        """What ``serial`` sent on ``subtopic``, oldest first."""
        return [s for s in self.seen if s.serial == serial and s.subtopic == subtopic]

    def last_state(self, serial: str) -> dict[str, Any]:
        """The last state of ``serial`` (empty dict: none yet)."""
        states = self.of(serial, "state")
        return states[-1].message if states else {}

    async def wait_for(
        self, what: Callable[[], bool], *, within: float, why: str | Callable[[], str] = ""
    ) -> None:
        """Wait until ``what()`` holds, at most ``within`` seconds."""
        for _ in range(round(within / _POLL_S) + 1):
            if what():
                return
            await asyncio.sleep(_POLL_S)
        said = why() if callable(why) else why
        raise AssertionError(f"timed out after {within} s waiting for {said}")

    async def send(self, serial: str, subtopic: str, message: Any) -> None:
        """Publish ``message`` (any JSON, or raw bytes) to ``serial``'s ``subtopic``."""
        topic = VehicleTopics(MANUFACTURER, serial).topic(subtopic)
        payload = message if isinstance(message, bytes) else json.dumps(message).encode()
        await self.client.publish(topic, payload, qos=1, timeout=_SEND_TIMEOUT_S)


@asynccontextmanager
async def probe(link: MqttLink) -> AsyncIterator[Probe]:
    """A connected probe, subscribed to every vehicle's topics."""
    async with link.client() as client:
        p = Probe(client)
        await client.subscribe(fleet_filter())

        async def collect() -> None:
            async for m in client.messages:
                parts = str(m.topic).split("/")
                payload = m.payload if isinstance(m.payload, bytes) else b""
                try:
                    message = json.loads(payload)
                except ValueError:
                    message = payload  # the probe hears its own malformed orders too
                p.seen.append(Seen(time.monotonic(), parts[3], parts[4], message))

        task = asyncio.get_running_loop().create_task(collect())
        try:
            yield p
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
