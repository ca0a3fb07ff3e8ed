"""Routers without a single point of failure: two routers linked to each other, every
client listing both; when one dies, its clients move to the other and the fleet hears
each other again; when it comes back, nothing is lost."""

from __future__ import annotations

import asyncio
import socket
from collections.abc import Iterator

import pytest

from objectplaces import RoleActivator
from objectplaces.security import TemporaryPki
from objectplaces.zenoh_node import start_zenoh_node
from objectplaces.zenoh_router import start_router
from tests.waiting import until

WITHIN = 60.0  # seconds: a loaded machine, never a speed


async def _move(node: RoleActivator) -> None:
    """Publish a new position every 0.1 s (x counts up), until cancelled."""
    x = 0.0
    while True:
        x += 1.0
        node.update_node_property("position", (x, 0.0))
        await asyncio.sleep(0.1)


def _x(node: RoleActivator) -> float:
    return float(node.properties.get("position", (0.0, 0.0))[0])


def _heard_x(node: RoleActivator) -> float:
    return float(node.view().get("a", {}).get("position", (0.0, 0.0))[0])


def _port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.fixture
def pki() -> Iterator[TemporaryPki]:
    with TemporaryPki(fleet="f") as made:
        # Every certificate before any router starts: a router re-reads the roster.
        for node in ("a", "b"):
            made.identity(node, role="agv")
        for router in ("r1", "r2"):
            made.identity(router, role="router", addresses=("127.0.0.1",))
        yield made


async def test_clients_move_to_the_other_router_when_theirs_dies(pki: TemporaryPki) -> None:
    ends = [f"tls/127.0.0.1:{_port()}", f"tls/127.0.0.1:{_port()}"]
    r1 = await start_router(tls=pki.identity("r1"), listen=[ends[0]])
    r2 = await start_router(tls=pki.identity("r2"), listen=[ends[1]], connect=[ends[0]])
    # a prefers r1, b prefers r2: the routers' link carries them to each other.
    a = await start_zenoh_node("a", tls=pki.identity("a"), mode="client", connect=ends)
    b = await start_zenoh_node("b", tls=pki.identity("b"), mode="client", connect=ends[::-1])
    moving = asyncio.create_task(_move(a))
    try:
        await until(lambda: _heard_x(b) > 0.0, WITHIN)
        await r1.close()  # a's router dies: a moves to r2
        killed_at = _x(a)
        await until(lambda: _heard_x(b) > killed_at, WITHIN)
        r1 = await start_router(tls=pki.identity("r1"), listen=[ends[0]], connect=[ends[1]])
        await r2.close()  # now the other one: both move to r1
        killed_at = _x(a)
        await until(lambda: _heard_x(b) > killed_at, WITHIN)
        assert not a.closed
        assert not b.closed
    finally:
        moving.cancel()
        await b.close()
        await a.close()
        await r1.close()
        await r2.close()


async def test_a_node_of_another_fleet_tag_is_no_member_and_told_why(pki: TemporaryPki) -> None:
    a = await start_zenoh_node("a", tls=pki.identity("a"), tag="layout:aaaa")
    b = await start_zenoh_node(
        "b", tls=pki.identity("b"), connect=a.address.split(","), tag="layout:bbbb"
    )
    try:
        a.update_node_property("position", (1.0, 0.0))
        await until(lambda: "a" in b.refusals(), WITHIN)
        assert b.refusals()["a"] == "another fleet: a runs 'layout:aaaa', b runs 'layout:bbbb'"
        await until(lambda: "b" in a.refusals(), WITHIN)
        assert "a" not in b.view()
        assert b.peers() == []
        assert b.transport_counters()["refused_tag"] == 1
    finally:
        await b.close()
        await a.close()
