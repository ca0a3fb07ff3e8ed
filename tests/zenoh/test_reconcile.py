"""A token report lost (links churning while many processes start on a loaded machine)
is made good by the periodic liveliness query: the node is a peer again within seconds."""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import AsyncIterator

import pytest

from objectplaces.transport import zenoh_transport
from objectplaces.zenoh_node import ZenohNode, start_zenoh_node

SECRET = b"fleet"


async def until_peers(node: ZenohNode, peers: list[str], within: float = 10.0) -> None:
    deadline = time.monotonic() + within
    while node.peers() != peers:
        assert time.monotonic() < deadline, f"{node.node_id} has {node.peers()}, not {peers}"
        await asyncio.sleep(0.01)


@contextlib.asynccontextmanager
async def linked_pair(
    monkeypatch: pytest.MonkeyPatch, reconcile_every: float
) -> AsyncIterator[tuple[ZenohNode, ZenohNode]]:
    """Nodes a and b, b connected to a, each a peer of the other; both closed after."""
    monkeypatch.setattr(zenoh_transport, "RECONCILE_EVERY", reconcile_every)
    a = await start_zenoh_node("a", secret=SECRET)
    b = await start_zenoh_node("b", secret=SECRET, connect=[a.address])
    try:
        await until_peers(a, ["b"])
        yield a, b
    finally:
        await b.close()
        await a.close()


async def test_a_lost_token_report_is_made_good(monkeypatch: pytest.MonkeyPatch) -> None:
    async with linked_pair(monkeypatch, 0.2) as (a, b):
        a._transport._alive.token_down("b", b._transport.incarnation)  # as if never reported
        assert a.peers() == []
        await until_peers(a, ["b"])


async def test_a_node_that_left_is_not_brought_back(monkeypatch: pytest.MonkeyPatch) -> None:
    async with linked_pair(monkeypatch, 0.05) as (a, b):
        await b.close()
        await until_peers(a, [])
        await asyncio.sleep(0.5)  # several queries, some sent before b went
        assert a.peers() == []
