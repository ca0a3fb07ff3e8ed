"""Late joiners hear the current properties at once, with no heartbeat to wait for:
the queryables answer a newcomer, a node that starts hearing a cell, and a node that
sees a new token. ``start_node`` dispatches on ``transport``."""

from __future__ import annotations

from typing import Any

import pytest

from objectplaces.core.errors import LocalProtocolError
from objectplaces.mesh import start_node
from objectplaces.zenoh_node import ZenohNode, start_zenoh_node
from tests.waiting import until

SECRET = b"a fleet secret of 32 bytes or more"


async def quiet(node_id: str, **kwargs: Any) -> ZenohNode:
    """A node that never republishes its properties (no heartbeat at all)."""
    return await start_zenoh_node(
        node_id, insecure=True, secret=SECRET, property_interval=None, **kwargs
    )


async def test_a_newcomer_hears_the_fleet_at_once() -> None:
    a = await quiet("a")
    b = await quiet("b", connect=[a.address])
    late: ZenohNode | None = None
    try:
        a.update_node_property("position", (1.0, 1.0))
        b.update_node_property("position", (2.0, 1.0))
        await until(lambda: "b" in a.view() and "a" in b.view())
        late = await quiet("late", connect=[b.address])
        await until(lambda: set(late.view()) == {"a", "b"} if late else False)
        assert late.view()["a"]["position"] == (1.0, 1.0)
    finally:
        for node in (late, b, a):
            if node is not None:
                await node.close()


async def test_a_scoped_node_entering_a_cell_hears_who_is_there_at_once() -> None:
    # Every node scoped: each publishes in its cell, and answers askers of that cell.
    here = await quiet("here", interest_radius=5.0)
    there = await quiet("there", connect=[here.address], interest_radius=5.0)
    scoped = await quiet("scoped", connect=[here.address], interest_radius=5.0)
    try:
        here.update_node_property("position", (1.0, 1.0))
        there.update_node_property("position", (501.0, 501.0))
        scoped.update_node_property("position", (2.0, 2.0))
        await until(lambda: "here" in scoped.view())
        assert "there" not in scoped.view()
        scoped.update_node_property("position", (502.0, 502.0))  # a cell "there" publishes in
        await until(lambda: "there" in scoped.view())
        assert scoped.view()["there"]["position"] == (501.0, 501.0)
    finally:
        for node in (scoped, there, here):
            await node.close()


async def test_start_node_takes_the_transport() -> None:
    node = await start_node(
        "z", transport="zenoh", insecure=True, secret=SECRET, listen=["tcp/127.0.0.1:0"]
    )
    try:
        assert isinstance(node, ZenohNode)
        assert node.address.startswith("tcp/127.0.0.1:")
    finally:
        await node.close()
    with pytest.raises(LocalProtocolError):
        await start_node("x", transport="pigeon", insecure=True, secret=SECRET)  # type: ignore[call-overload]
