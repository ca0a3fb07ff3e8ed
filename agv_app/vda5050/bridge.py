"""The MQTT shell around a :class:`~agv_app.vda5050.endpoint.VdaEndpoint`: one client per AGV.

:func:`run_bridge` connects the vehicle to the broker (``aiomqtt``, an asyncio client
on paho, with TCP_NODELAY) with ``connection: CONNECTION_BROKEN`` as its last will,
says ``ONLINE``, publishes its factsheet, subscribes to its ``order`` and
``instantActions``, and publishes what the endpoint says is due every ``tick_s``. When
cancelled it says ``OFFLINE`` and disconnects. A lost broker is retried every
``retry_s`` for as long as the bridge runs.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket

import aiomqtt

from agv_app.vda5050.endpoint import Outgoing, VdaEndpoint
from agv_app.vda5050.messages import connection_message
from agv_app.vda5050.topics import BrokerAddress

__all__ = ["BridgeCounters", "honour_cancellation", "run_bridge"]

_log = logging.getLogger(__name__)
_NODELAY = (socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
_OFFLINE_TIMEOUT_S = 1.0


class BridgeCounters:
    """Messages the bridge published and received, and whether it is connected."""

    def __init__(self) -> None:
        self.published = 0
        self.received = 0
        self.connected = False


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
    await client.subscribe([(topics.topic("order"), 1), (topics.topic("instantActions"), 1)])
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
            for out in endpoint.handle(subtopic, payload):
                await _publish(client, endpoint, out)
                counters.published += 1
                honour_cancellation()

    async with asyncio.TaskGroup() as tg:
        tg.create_task(publish_due())
        tg.create_task(answer())


async def run_bridge(
    endpoint: VdaEndpoint,
    broker: BrokerAddress,
    *,
    counters: BridgeCounters | None = None,
    tick_s: float = 0.05,
    retry_s: float = 1.0,
    tcp_nodelay: bool = True,
) -> None:
    """Speak VDA 5050 for one vehicle until cancelled (see the module doc).

    Args:
        endpoint: the vehicle's interface.
        broker: where the broker listens.
        counters: updated with what goes through the bridge.
        tick_s: how often due messages are looked for.
        retry_s: wait before connecting again after the broker was lost.
        tcp_nodelay: set TCP_NODELAY on the socket (off only to measure what it saves).
    """
    counters = counters or BridgeCounters()
    topics = endpoint.topics
    while True:
        will = _connection(endpoint, "CONNECTION_BROKEN")
        client = aiomqtt.Client(
            broker.host,
            broker.port,
            identifier=f"{topics.manufacturer}-{topics.serial_number}",
            will=aiomqtt.Will(topics.topic("connection"), will.payload(), qos=1, retain=True),
            socket_options=[_NODELAY] if tcp_nodelay else [],
            keepalive=5,
        )
        try:
            async with client:
                counters.connected = True
                try:
                    await _serve_connection(client, endpoint, counters, tick_s)
                except asyncio.CancelledError:
                    with contextlib.suppress(aiomqtt.MqttError, TimeoutError):
                        async with asyncio.timeout(_OFFLINE_TIMEOUT_S):
                            await _publish(client, endpoint, _connection(endpoint, "OFFLINE"))
                    raise
        except* aiomqtt.MqttError as group:
            _log.warning("VDA 5050 bridge of %s: %s", topics.serial_number, group.exceptions[0])
        finally:
            counters.connected = False
        await asyncio.sleep(retry_s)
