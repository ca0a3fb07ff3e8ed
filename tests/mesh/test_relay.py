"""Two node processes on two hosts (network namespaces), every byte between them through
a relay on the path: it sees no plaintext, and what it injects is never applied."""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Iterator

import msgpack
import pytest

from objectplaces.security import TemporaryPki
from tests.mesh.procs import Cluster, NodeProcess
from tests.netns import Network

pytestmark = pytest.mark.processes

MARKER = "plaintext-marker-7f3a"
_CAPTURE_LIMIT = 4 << 20


class Relay:
    """A TCP relay on the path between two hosts: it keeps what passes and can inject."""

    def __init__(self, listen_host: str, target: tuple[str, int]) -> None:
        self.listen_host = listen_host
        self.target = target
        self.port = 0
        self.captured = bytearray()
        self.connections = 0
        self._upstream: list[asyncio.StreamWriter] = []
        self._writers: list[asyncio.StreamWriter] = []
        self._server: asyncio.Server | None = None

    async def start(self) -> None:
        self._server = await asyncio.start_server(self._serve, self.listen_host, 0)
        self.port = self._server.sockets[0].getsockname()[1]

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.connections += 1
        self._writers.append(writer)
        try:
            up_reader, up_writer = await asyncio.open_connection(*self.target)
        except OSError:
            writer.close()
            return
        self._writers.append(up_writer)
        self._upstream.append(up_writer)
        async with asyncio.TaskGroup() as tg:
            tg.create_task(self._pump(reader, up_writer))
            tg.create_task(self._pump(up_reader, writer))
        self._upstream.remove(up_writer)

    async def _pump(self, source: asyncio.StreamReader, sink: asyncio.StreamWriter) -> None:
        with contextlib.suppress(OSError):
            while data := await source.read(65536):
                if len(self.captured) < _CAPTURE_LIMIT:
                    self.captured += data
                sink.write(data)
                await sink.drain()
        with contextlib.suppress(OSError):
            sink.close()

    def inject(self, data: bytes) -> int:
        """Write ``data`` into every open connection towards the target; how many."""
        for writer in self._upstream:
            writer.write(data)
        return len(self._upstream)

    async def close(self) -> None:
        if self._server is not None:
            self._server.close()
        for writer in self._writers:
            writer.close()
            with contextlib.suppress(OSError):
                await writer.wait_closed()
        if self._server is not None:
            await self._server.wait_closed()


def forged_property_frame(x: float, y: float) -> bytes:
    """A WebSocket binary frame holding a property update with the highest sequence
    number, as a relay would write it onto a plain link."""
    payload = bytes(msgpack.packb([1, 2**53 - 1, {"position": [x, y]}]))
    assert len(payload) < 126
    return bytes([0x82, len(payload)]) + payload


def position_of(node: NodeProcess, peer: str) -> object:
    mark = len(node.events)
    node.send(cmd="view")
    return node.wait_event("view", since=mark)["view"].get(peer, {}).get("position")


@pytest.fixture
def network() -> Iterator[Network]:
    with Network() as net:
        yield net


async def test_a_relay_between_two_hosts_sees_no_plaintext_and_cannot_inject(
    network: Network,
) -> None:
    host_a, host_b = network.host("a"), network.host("b")
    with TemporaryPki(fleet="relay") as pki:
        for node_id in ("a", "b"):
            pki.identity(node_id, role="agv")
        relay = Relay(host_a.gateway, (host_b.address, 7100))
        await relay.start()
        cluster = Cluster(pki=pki.directory, run_seconds=240.0)
        try:
            b = cluster.start(
                "b",
                "--listen", f"{host_b.address}:7100",
                "--property-interval", "0.3",
                prefix=network.command(host_b, []),
            )  # fmt: skip
            a = cluster.start(
                "a",
                "--listen", f"{host_a.address}:7101",
                "--join", f"{host_a.gateway}:{relay.port}",
                "--property", "position=[12,3]",
                "--property", f"note={MARKER}",
                "--property-interval", "0.3",
                prefix=network.command(host_a, []),
            )  # fmt: skip
            await asyncio.to_thread(b.wait_peers, 1, timeout=60)

            def sees(x: float) -> None:
                deadline = time.monotonic() + 60
                while position_of(b, "a") != [x, 3.0]:
                    assert time.monotonic() < deadline, "b never saw a's position"
                    time.sleep(0.1)  # polling a live process, not an assertion

            await asyncio.to_thread(sees, 12.0)
            assert relay.connections >= 1
            assert len(relay.captured) > 1000
            for plain in (MARKER.encode(), b"position", b"note"):
                assert plain not in relay.captured, f"{plain!r} crossed the relay in clear"

            # The relay injects a forged update: TLS refuses the bytes and drops the link.
            assert relay.inject(forged_property_frame(999.0, 999.0)) >= 1
            await asyncio.to_thread(b.wait_stderr, "link with a closed", timeout=60)
            assert position_of(b, "a") == [12.0, 3.0]
            # The link comes back through the relay, and a is followed again.
            a.send(cmd="move", x=14, y=3)
            await asyncio.to_thread(sees, 14.0)
            assert b.proc.poll() is None
            assert a.proc.poll() is None
        finally:
            cluster.close()
            await relay.close()
