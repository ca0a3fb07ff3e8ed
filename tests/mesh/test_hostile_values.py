"""A peer that passed authentication publishes positions the node cannot use.

Whatever handling such a frame does, the node lives: either its machine refuses the
value (the link stays, and a marker frame sent after it on the same link is applied),
or handling raises and the transport closes that one link with code 1011 and counts it.
Never does the node's mesh stop. Both ends of a link are tried: the hostile peer dials
the node, and the node dials the hostile peer (its seed). Then the honest peer is still
followed.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import msgpack
import pytest
from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed

from tests.credentials import TEST_SECRET, write_secret
from tests.mesh.procs import Cluster, NodeProcess
from tests.mesh.rawpeer import accept_handshake, authenticate, open_raw
from tests.mesh.test_bad_input import follows

pytestmark = pytest.mark.processes

SECRET = TEST_SECRET
HOSTILE_POSITIONS: list[object] = [
    ["x", "y"],
    [math.nan, 0],
    [math.inf, -math.inf],
    [None, 1],
]


def property_frame(seq: int, values: dict[str, Any]) -> bytes:
    """A well-formed property frame (type 1, any values)."""
    return bytes(msgpack.packb([1, seq, values]))


@pytest.fixture
def cluster(tmp_path: Path):
    cluster = Cluster(write_secret(tmp_path), run_seconds=60.0)
    try:
        yield cluster
    finally:
        cluster.close()


@contextlib.asynccontextmanager
async def hostile_seed(accepted: asyncio.Queue[ServerConnection]) -> AsyncIterator[str]:
    """A seed that authenticates whoever dials it and hands each link to the test."""

    async def handler(ws: ServerConnection) -> None:
        await accept_handshake(ws, SECRET, node="zz-hostile")
        await accepted.put(ws)
        await ws.wait_closed()

    async with serve(handler, "127.0.0.1", 0, compression=None) as server:
        yield f"127.0.0.1:{server.sockets[0].getsockname()[1]}"


def view_of(node: NodeProcess) -> dict[str, Any]:
    mark = len(node.events)
    node.send(cmd="view")
    return dict(node.wait_event("view", since=mark)["view"])


async def outcome(node: NodeProcess, ws: Any, sender: str, seq: int, position: object) -> str:
    """Send an unusable position, then a marker, on one link; say what the node did.

    Returns:
        "closed" when the node closed the link with 1011, "refused" when it kept the link
        and applied the marker that came after the hostile frame.
    """
    await ws.send(property_frame(seq, {"position": position}))
    await ws.send(property_frame(seq + 1, {"marker": seq + 1}))
    deadline = time.monotonic() + 15
    while True:
        closed: ConnectionClosed | None = None
        try:
            async with asyncio.timeout(0.05):
                await ws.recv()  # gossip and subscriptions from the node: ignored
        except TimeoutError:
            pass
        except ConnectionClosed as exc:
            closed = exc
        if closed is not None:
            rcvd = closed.rcvd
            assert rcvd is not None, "the node dropped the link without a close frame"
            assert rcvd.code == 1011, rcvd
            assert "failed handling" in rcvd.reason
            return "closed"
        view = await asyncio.to_thread(view_of, node)
        if view.get(sender, {}).get("marker") == seq + 1:
            return "refused"
        assert time.monotonic() < deadline, f"{position!r}: neither closed nor refused: {view}"


async def test_unusable_positions_never_stop_the_node(cluster: Cluster) -> None:
    accepted: asyncio.Queue[ServerConnection] = asyncio.Queue()
    outcomes: list[str] = []
    async with hostile_seed(accepted) as seed:
        # The collector indexes positions (its group is `within`), so a hostile position
        # reaches the index, where a node without validation raises.
        a = cluster.start(
            "a", "--role", "collector", "--property", "position=[0,0]", "--join", seed,
            "--property-interval", "0.5",
        )  # fmt: skip
        address = await asyncio.to_thread(lambda: a.address)
        b = cluster.start("b", "--property", "position=[1,0]", "--join", address)
        await asyncio.to_thread(a.wait_peers, 1)

        # The node dials its hostile seed, and again after each link is gone.
        for n, position in enumerate(HOSTILE_POSITIONS):
            async with asyncio.timeout(30):
                ws = await accepted.get()
            outcomes.append(await outcome(a, ws, "zz-hostile", 10 * n + 1, position))
            await ws.close(1000, "next")

        # Hostile peers dialing in.
        for n, position in enumerate(HOSTILE_POSITIONS):
            dialer = await open_raw(address)
            await authenticate(dialer, SECRET, node=f"hostile-{n}")
            outcomes.append(await outcome(a, dialer, f"hostile-{n}", 1, position))
            await dialer.close()

        await follows(a, b, 2.0)
        mark = len(a.events)
        a.send(cmd="stats")
        stats = await asyncio.to_thread(a.wait_event, "stats", since=mark)
        assert stats["peers"]["b"]["connected"]
        assert stats["counters"].get("links_closed_failed", 0) == outcomes.count("closed")
        assert not any("mesh stopped" in line or "node is closed" in line for line in a.stderr)
        assert a.quit() == 0
        assert b.quit() == 0
    print("outcomes:", outcomes)  # which part held: the machine (refused) or the transport
