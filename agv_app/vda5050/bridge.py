"""The MQTT shell around a :class:`~agv_app.vda5050.endpoint.VdaEndpoint`: one client per AGV.

:func:`run_bridge` connects the vehicle to the broker (``aiomqtt``, an asyncio client
on paho, with TCP_NODELAY) over its :class:`~agv_app.vda5050.link.MqttLink` (mutual
TLS with the vehicle's certificate, whose id is its serial number) with ``connection:
CONNECTION_BROKEN`` as its last will, says ``ONLINE``, publishes its factsheet,
subscribes to its ``order`` and ``instantActions``, and publishes what the endpoint
says is due every ``tick_s``. QoS is what VDA 5050 3.0 section 4.1 asks: 1 for
``connection`` (retained, 6.5), 0 for every other topic, the subscriptions too. When
cancelled it says ``OFFLINE`` and disconnects. A lost broker is retried every
``retry_s`` for as long as the bridge runs; a connection that fails is diagnosed
(:func:`~agv_app.vda5050.link.probe_broker`) and logged in words, once for each new
reason.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Coroutine
from typing import Any

import aiomqtt

from agv_app.vda5050.endpoint import Outgoing, VdaEndpoint
from agv_app.vda5050.link import BrokerError, MqttLink, check_broker
from agv_app.vda5050.messages import connection_message
from objectplaces.security import CredentialError

__all__ = ["BridgeCounters", "ConnectionTrouble", "honour_cancellation", "run_bridge"]

_log = logging.getLogger(__name__)
_OFFLINE_TIMEOUT_S = 1.0


class BridgeCounters:
    """Messages the bridge published and received, whether it is connected, and how
    often it connected."""

    def __init__(self) -> None:
        self.published = 0
        self.received = 0
        self.connected = False
        self.connects = 0


class ConnectionTrouble:
    """Says in words why a client cannot connect, once for each new reason (a bridge
    retries every second; the log should not)."""

    def __init__(self, who: str) -> None:
        self.who = who
        self.last: str | None = None

    async def failed(self, link: MqttLink, error: Exception, *, connected: bool) -> str:
        """Note that the connection failed (or, ``connected``, was lost) with ``error``;
        log why if that is news. Returns the reason."""
        reason = str(error) or type(error).__name__
        if not connected:
            try:
                await check_broker(link)
            except BrokerError as diagnosed:
                reason = str(diagnosed)
        if reason != self.last:
            self.last = reason
            what = "connection lost" if connected else "cannot connect"
            _log.warning("%s: %s: %s", self.who, what, reason)
        return reason

    def connected(self) -> None:
        """The connection is up: the next failure is news again."""
        self.last = None


def _connection(endpoint: VdaEndpoint, state: str) -> Outgoing:
    return Outgoing("connection", connection_message(endpoint.headers, state), qos=1, retain=True)


async def _publish(client: aiomqtt.Client, endpoint: VdaEndpoint, out: Outgoing) -> None:
    await client.publish(
        endpoint.topics.topic(out.subtopic), out.payload(), qos=out.qos, retain=out.retain
    )


def honour_cancellation() -> None:
    """Raise CancelledError if this task was asked to stop.

    ``asyncio.wait_for`` in Python 3.11, which the client awaits a publication through,
    can return the result of a publication that completes as the task is cancelled and
    drop the cancellation; the loops below check after each publication, so a bridge
    always stops when asked.
    """
    task = asyncio.current_task()
    if task is not None and task.cancelling():
        raise asyncio.CancelledError


async def _serve_connection(
    client: aiomqtt.Client, endpoint: VdaEndpoint, counters: BridgeCounters, tick_s: float
) -> None:
    """While connected: publish what is due, answer what arrives, until cancelled."""
    topics = endpoint.topics
    for first in (_connection(endpoint, "ONLINE"), endpoint.factsheet()):
        await _publish(client, endpoint, first)
        counters.published += 1
        honour_cancellation()
    await client.subscribe([(topics.topic("order"), 0), (topics.topic("instantActions"), 0)])
    loop = asyncio.get_running_loop()

    async def publish_due() -> None:
        while True:
            for out in endpoint.due(loop.time()):
                await _publish(client, endpoint, out)
                counters.published += 1
                honour_cancellation()
            await asyncio.sleep(tick_s)

    async def answer() -> None:
        async for message in client.messages:
            counters.received += 1
            subtopic = str(message.topic).rsplit("/", 1)[-1]
            payload = message.payload if isinstance(message.payload, bytes) else b""
            for out in endpoint.handle(subtopic, payload, now=loop.time()):
                await _publish(client, endpoint, out)
                counters.published += 1
                honour_cancellation()

    await _until_one_fails(publish_due(), answer())


async def _until_one_fails(*jobs: Coroutine[Any, Any, None]) -> None:
    """Run ``jobs`` until one of them ends, then cancel the rest; raise what it raised.

    Not a TaskGroup with an empty body: in Python 3.11 a child's failure there leaves a
    cancellation request on the awaiting task (``Task.cancelling()`` stays 1), and
    :func:`honour_cancellation` would then stop the bridge on its next connection.
    """
    tasks = [asyncio.ensure_future(job) for job in jobs]
    try:
        done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
    for task in done:
        task.result()


async def run_bridge(
    endpoint: VdaEndpoint,
    link: MqttLink,
    *,
    counters: BridgeCounters | None = None,
    tick_s: float = 0.05,
    retry_s: float = 1.0,
    tcp_nodelay: bool = True,
) -> None:
    """Speak VDA 5050 for one vehicle until cancelled (see the module doc).

    Args:
        endpoint: the vehicle's interface.
        link: the broker and the vehicle's identity (its id: the serial number).
        counters: updated with what goes through the bridge.
        tick_s: how often due messages are looked for.
        retry_s: wait before connecting again after the broker was lost.
        tcp_nodelay: set TCP_NODELAY on the socket (off only to measure what it saves).

    Raises:
        CredentialError: the link's certificate names another id than the serial number
            (the broker would let it publish nothing of this vehicle's).
    """
    counters = counters or BridgeCounters()
    topics = endpoint.topics
    if link.client_id is not None and link.client_id != topics.serial_number:
        assert link.identity is not None
        raise CredentialError(
            f"certificate {link.identity.cert} names {link.client_id!r}, but the vehicle's "
            f"serial number is {topics.serial_number!r}"
        )
    trouble = ConnectionTrouble(f"VDA 5050 bridge of {topics.serial_number}")
    while True:
        will = _connection(endpoint, "CONNECTION_BROKEN")
        client = link.client(
            identifier=f"{topics.manufacturer}-{topics.serial_number}",
            will=aiomqtt.Will(topics.topic("connection"), will.payload(), qos=1, retain=True),
            tcp_nodelay=tcp_nodelay,
            keepalive=5,
        )
        connected = False
        try:
            async with client:
                counters.connected = connected = True
                counters.connects += 1
                trouble.connected()
                try:
                    await _serve_connection(client, endpoint, counters, tick_s)
                except asyncio.CancelledError:
                    with contextlib.suppress(aiomqtt.MqttError, TimeoutError):
                        async with asyncio.timeout(_OFFLINE_TIMEOUT_S):
                            await _publish(client, endpoint, _connection(endpoint, "OFFLINE"))
                    raise
        except* aiomqtt.MqttError as group:
            await trouble.failed(link, group.exceptions[0], connected=connected)
        finally:
            counters.connected = False
        await asyncio.sleep(retry_s)
