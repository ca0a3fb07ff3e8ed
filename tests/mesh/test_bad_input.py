"""A node process refuses wrong secrets and versions, and survives bad frames and floods.

After every kind of abuse the node must still serve its honest peer: it keeps following
that peer's moves.
"""

from __future__ import annotations

import asyncio
import os
import time
from pathlib import Path

import msgpack
import pytest
from websockets.exceptions import ConnectionClosed

from objectplaces.core import codec
from objectplaces.core.messages import PropertyUpdate
from objectplaces.transport.mesh_frames import HELLO, encode_batch
from tests.credentials import TEST_SECRET, write_secret
from tests.mesh.procs import Cluster, NodeProcess
from tests.mesh.rawpeer import authenticate, open_raw

pytestmark = pytest.mark.processes

MAX_FRAME = 4096
FLOOD_RATE = 200


@pytest.fixture
def cluster(tmp_path: Path):
    cluster = Cluster(write_secret(tmp_path), run_seconds=60.0)
    try:
        yield cluster
    finally:
        cluster.close()


async def closed_with(ws, send: list[bytes | str]) -> tuple[int, str]:
    """Send frames, then wait for the node to close the link; returns (code, reason)."""

    async def talk() -> None:
        async with asyncio.timeout(15):
            for frame in send:
                await ws.send(frame)
            while True:
                await ws.recv()

    with pytest.raises(ConnectionClosed) as info:
        await talk()
    rcvd = info.value.rcvd
    assert rcvd is not None, "the node dropped the link without a close frame"
    return rcvd.code, rcvd.reason


async def follows(node: NodeProcess, peer: NodeProcess, x: float) -> None:
    """``node`` still hears ``peer``: it sees ``peer`` move to ``(x, 0)``."""
    peer.send(cmd="move", x=x, y=0)

    def saw_move() -> None:
        deadline = time.monotonic() + 15
        while True:
            mark = len(node.events)
            node.send(cmd="view")
            view = node.wait_event("view", since=mark)["view"]
            if view.get(peer.node_id, {}).get("position") == [x, 0.0]:
                return
            assert time.monotonic() < deadline, f"stale view {view}"
            time.sleep(0.02)  # poll, not an assertion

    await asyncio.to_thread(saw_move)


async def test_abuse_is_refused_and_the_node_keeps_serving(
    cluster: Cluster, tmp_path: Path
) -> None:
    limits = ["--max-frame", str(MAX_FRAME), "--flood-rate", str(FLOOD_RATE)]
    limits += ["--flood-burst", "50", "--property-interval", "0.5"]
    a = cluster.start("a", "--property", "position=[0,0]", *limits)
    address = await asyncio.to_thread(lambda: a.address)
    b = cluster.start("b", "--property", "position=[1,0]", "--join", address, *limits)
    await asyncio.to_thread(a.wait_peers, 1)
    await follows(a, b, 2.0)

    # A node with the wrong secret is refused, and both sides say so.
    wrong = write_secret(tmp_path, b"not the secret, though long enough", name="wrong")
    intruder = cluster.start("c", "--join", address, secret_file=wrong)
    await asyncio.to_thread(a.wait_stderr, "authentication failed for 'c'")
    await asyncio.to_thread(intruder.wait_stderr, "authentication failed")
    assert intruder.quit() == 0
    assert not any("c" in e.get("peers", ()) for e in a.events)

    # A raw client with the wrong secret, and one of another protocol version.
    ws = await open_raw(address)
    with pytest.raises(ConnectionClosed) as info:
        await authenticate(ws, b"guess")
    assert info.value.rcvd is not None
    assert info.value.rcvd.code == 1008
    assert "authentication failed" in info.value.rcvd.reason
    ws = await open_raw(address)
    hello = msgpack.packb([HELLO, 99, "x", "127.0.0.1:9", 1, b"0" * 16])
    code, reason = await closed_with(ws, [hello])
    assert (code, "version" in reason) == (1008, True)

    # Authenticated, then misbehaving: each link is closed with its reason.
    secret = TEST_SECRET
    cases: list[tuple[list[bytes | str], int, str]] = [
        ([b"\x93\xc1\xc1"], 1002, "malformed"),
        ([msgpack.packb([99, 1, 2])], 1002, "unknown"),
        ([msgpack.packb([codec.FIRST_TRANSPORT_TYPE + 20])], 1002, "unknown"),
        (["a text frame"], 1003, "text"),
        ([os.urandom(MAX_FRAME + 1)], 1009, ""),
        (
            [encode_batch([encode_batch([codec.encode(PropertyUpdate(1, {}))])])],
            1002,
            "batch inside",
        ),
        ([encode_batch([b"\x93\xc1\xc1"])], 1002, "malformed"),
        ([codec.encode(PropertyUpdate(n + 1, {"spam": n})) for n in range(2000)], 1008, "flood"),
    ]
    for frames, expected_code, expected_reason in cases:
        ws = await open_raw(address)
        await authenticate(ws, secret, node=f"intruder-{expected_code}")
        code, reason = await closed_with(ws, frames)
        assert code == expected_code, (code, reason)
        assert expected_reason in reason

    # Frames queued together travel as one batch: each is handled as if sent alone.
    ws = await open_raw(address)
    await authenticate(ws, secret, node="batcher")
    moves = [codec.encode(PropertyUpdate(n, {"position": (float(n), 0.0)})) for n in (1, 2, 3)]
    await ws.send(encode_batch(moves))

    def saw_batch() -> None:
        deadline = time.monotonic() + 15
        while True:
            mark = len(a.events)
            a.send(cmd="view")
            view = a.wait_event("view", since=mark)["view"]
            if view.get("batcher", {}).get("position") == [3.0, 0.0]:
                return
            assert time.monotonic() < deadline, f"batch not applied: {view}"
            time.sleep(0.02)  # poll, not an assertion

    await asyncio.to_thread(saw_batch)
    await ws.close()

    # The node kept running, kept its honest link, and still follows b.
    await follows(a, b, 3.0)
    mark = len(a.events)
    a.send(cmd="stats")
    stats = await asyncio.to_thread(a.wait_event, "stats", since=mark)
    assert stats["peers"]["b"]["connected"]
    assert stats["peers"]["b"]["reconnects"] == 0
    assert stats["counters"]["links_closed_bad_input"] >= 4
    assert stats["counters"]["refused_auth"] >= 2
    assert stats["counters"]["refused_version"] == 1
    assert a.quit() == 0
    assert b.quit() == 0
