"""A peer that passed authentication publishes values the node cannot use.

Whatever handling one frame raises, the transport closes that one link with a reason
and counts it; the node, its mesh and its honest links carry on. Both ends of a link are
tried: the hostile peer dials the node, and the node dials the hostile peer (its seed).
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import AsyncIterator
from pathlib import Path

import msgpack
import pytest
from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed

from tests.mesh.procs import Cluster
from tests.mesh.rawpeer import accept_handshake, authenticate, open_raw
from tests.mesh.test_bad_input import closed_with, follows

pytestmark = pytest.mark.processes

SECRET = b"the right secret"
HOSTILE_POSITIONS: list[object] = [
    ["x", "y"],
    [math.nan, 0],
    [math.inf, -math.inf],
    [None, 1],
]


def hostile_frame(seq: int, position: object) -> bytes:
    """A well-formed property frame (type 1) whose position is unusable."""
    return bytes(msgpack.packb([1, seq, {"position": position}]))


@pytest.fixture
def cluster(tmp_path: Path):
    secret = tmp_path / "secret"
    secret.write_bytes(SECRET)
    cluster = Cluster(secret, run_seconds=60.0)
    try:
        yield cluster
    finally:
        cluster.close()


@contextlib.asynccontextmanager
async def hostile_listener(
    closes: list[tuple[int, str]], all_closed: asyncio.Event
) -> AsyncIterator[str]:
    """A seed that authenticates whoever dials it, then sends one hostile frame per link."""
    frames = iter(hostile_frame(n + 1, p) for n, p in enumerate(HOSTILE_POSITIONS))

    async def handler(ws: ServerConnection) -> None:
        await accept_handshake(ws, SECRET, node="zz-hostile")
        frame = next(frames, None)
        if frame is None:
            await ws.wait_closed()
            return
        with contextlib.suppress(ConnectionClosed):
            await ws.send(frame)
            async with asyncio.timeout(15):
                while True:
                    await ws.recv()
        rcvd = ws.protocol.close_rcvd
        closes.append((rcvd.code, rcvd.reason) if rcvd is not None else (0, "no close frame"))
        if len(closes) == len(HOSTILE_POSITIONS):
            all_closed.set()

    async with serve(handler, "127.0.0.1", 0, compression=None) as server:
        port = server.sockets[0].getsockname()[1]
        yield f"127.0.0.1:{port}"


async def test_unusable_positions_close_one_link_and_the_node_keeps_following(
    cluster: Cluster,
) -> None:
    closes: list[tuple[int, str]] = []
    all_closed = asyncio.Event()
    async with hostile_listener(closes, all_closed) as seed:
        # The collector indexes positions (its group is `within`), so a hostile position
        # reaches the index, where the unfixed node raised.
        a = cluster.start(
            "a", "--role", "collector", "--property", "position=[0,0]", "--join", seed,
            "--property-interval", "0.5",
        )  # fmt: skip
        address = await asyncio.to_thread(lambda: a.address)
        b = cluster.start("b", "--property", "position=[1,0]", "--join", address)
        await asyncio.to_thread(a.wait_peers, 1)

        # The node dials its hostile seed again and again: one link closed per value.
        async with asyncio.timeout(30):
            await all_closed.wait()
        for code, reason in closes:
            assert code == 1011, closes
            assert "failed" in reason, closes

        # A hostile peer dialing in: the same.
        for n, position in enumerate(HOSTILE_POSITIONS):
            ws = await open_raw(address)
            await authenticate(ws, SECRET, node=f"hostile-{n}")
            code, reason = await closed_with(ws, [hostile_frame(1, position)])
            assert code == 1011, (position, code, reason)

        await follows(a, b, 2.0)
        mark = len(a.events)
        a.send(cmd="stats")
        stats = await asyncio.to_thread(a.wait_event, "stats", since=mark)
        assert stats["peers"]["b"]["connected"]
        assert stats["counters"]["links_closed_failed"] == 2 * len(HOSTILE_POSITIONS)
        assert not any("mesh stopped" in line or "node is closed" in line for line in a.stderr)
        assert a.quit() == 0
        assert b.quit() == 0
