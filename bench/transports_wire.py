"""Bytes one Zenoh node writes to another per property update, counted on the wire.

Two Zenoh nodes in this process; the second connects to the first through a TCP relay
that counts the bytes it forwards each way. The first publishes position updates a
few milliseconds apart (each travels alone, as in the fan-out phase); the bytes the
relay carried towards the subscriber, less those of an idle interval as long, divided
by the updates, are the bytes per update: payload, key and Zenoh framing (TCP/IP
headers not included).
"""

from __future__ import annotations

import asyncio
import contextlib

from objectplaces.zenoh_node import start_zenoh_node

__all__ = ["zenoh_bytes_per_update"]


class Relay:
    """A TCP relay on 127.0.0.1 counting bytes per direction."""

    def __init__(self, target_port: int) -> None:
        self.target_port = target_port
        self.to_target = 0
        self.to_client = 0
        self.port = 0
        self._server: asyncio.Server | None = None

    async def start(self) -> None:
        self._server = await asyncio.start_server(self._serve, "127.0.0.1", 0)
        self.port = self._server.sockets[0].getsockname()[1]

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.target_port)

        async def pump(src: asyncio.StreamReader, dst: asyncio.StreamWriter, up: bool) -> None:
            with contextlib.suppress(ConnectionError):
                while data := await src.read(65536):
                    if up:
                        self.to_target += len(data)
                    else:
                        self.to_client += len(data)
                    dst.write(data)
                    await dst.drain()
            dst.close()

        await asyncio.gather(pump(reader, up_writer, True), pump(up_reader, writer, False))

    async def close(self) -> None:
        if self._server is not None:
            self._server.close()


async def zenoh_bytes_per_update(secret: bytes, count: int = 500, gap: float = 0.004) -> float:
    """Bytes the subscriber's link carries per position update (see the module doc)."""
    subscriber = await start_zenoh_node("sub", insecure=True, secret=secret, property_interval=None)
    port = int(subscriber.address.rsplit(":", 1)[1])
    relay = Relay(port)
    await relay.start()
    publisher = await start_zenoh_node(
        "pub", insecure=True, secret=secret, listen=[],
        connect=[f"tcp/127.0.0.1:{relay.port}"],
        property_interval=None,
    )  # fmt: skip
    try:
        async with asyncio.timeout(10):
            await subscriber.wait_for_peers(1)
        heard = 0

        def observe(node: str, name: str, value: object) -> None:
            nonlocal heard
            heard += 1

        subscriber.register_node_property_observer(observe)
        publisher.update_node_property("position", (42.137, 17.5))
        publisher.update_node_property("hull_length", 3.2)
        await asyncio.sleep(0.5)
        before = relay.to_target
        await asyncio.sleep(count * gap + 0.3)
        idle = relay.to_target - before
        before = relay.to_target
        for i in range(count):
            publisher.update_node_property("position", (42.137 + i / 1000, 17.5))
            await asyncio.sleep(gap)
        await asyncio.sleep(0.3)
        assert heard > 0, "the subscriber heard nothing through the relay"
        return (relay.to_target - before - idle) / count
    finally:
        await publisher.close()
        await subscriber.close()
        await relay.close()
