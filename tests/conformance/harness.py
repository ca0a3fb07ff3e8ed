"""Ways to run the same scenario: the simulated network, in-process mesh nodes, and
in-process Zenoh nodes (peers, or clients of a router).

A scenario only adds nodes, calls the ``RoleActivator`` API, lets nodes leave and waits
for conditions; it never knows which transport carries it.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from functools import partial
from typing import Any, Protocol

from objectplaces import RoleActivator
from objectplaces.mesh import MeshNode, start_mesh_node
from objectplaces.sim import SimulatedNetwork
from objectplaces.zenoh_node import ZenohNode, start_zenoh_node
from objectplaces.zenoh_router import ZenohRouter, start_router
from tests.mesh.rawpeer import authenticate, open_raw
from tests.zenoh.intruder import open_fleet_session

INTERVAL = 0.2
FAILURE_TIMEOUT = 1.0


class Harness(Protocol):
    """What the scenarios need from a network."""

    name: str

    async def add(self, node_id: str, **kwargs: Any) -> RoleActivator:
        """Add a node; it is linked with every other node when this returns."""
        ...

    async def leave(self, node_id: str) -> None:
        """Let a node leave gracefully."""
        ...

    async def hostile(self, target: str, frames: list[bytes]) -> None:
        """Hand ``target`` each frame as if an authenticated peer (no node) sent it."""
        ...

    async def until(self, predicate: Callable[[], bool], within: float = 10.0) -> None:
        """Let time pass until ``predicate()`` holds; fail after ``within`` seconds."""
        ...

    async def close(self) -> None:
        """Stop every node."""
        ...


class SimHarness:
    """The seeded simulated network, in virtual time."""

    name = "sim"

    def __init__(self) -> None:
        self.net = SimulatedNetwork(
            seed=4, delay=0.002, jitter=0.001, property_interval=INTERVAL,
            failure_timeout=FAILURE_TIMEOUT,
        )  # fmt: skip

    async def add(self, node_id: str, **kwargs: Any) -> RoleActivator:
        node = self.net.add_node(node_id, **kwargs)
        self.net.run_for(0.01)
        return node

    async def leave(self, node_id: str) -> None:
        self.net.leave(node_id)

    async def hostile(self, target: str, frames: list[bytes]) -> None:
        for frame in frames:
            self.net.inject("intruder", target, frame)
        self.net.run_for(0.01)

    async def until(self, predicate: Callable[[], bool], within: float = 10.0) -> None:
        assert self.net.run_until(predicate, within), f"not within {within}s of virtual time"

    async def close(self) -> None:
        pass


class MeshHarness:
    """Mesh nodes in this process, linked over 127.0.0.1."""

    name = "mesh"

    def __init__(self) -> None:
        self.nodes: dict[str, MeshNode] = {}
        self.secret = b"conformance"

    async def add(self, node_id: str, **kwargs: Any) -> RoleActivator:
        seeds = [next(iter(self.nodes.values())).address] if self.nodes else []
        node = await start_mesh_node(
            node_id,
            join=seeds,
            secret=self.secret,
            property_interval=INTERVAL,
            failure_timeout=FAILURE_TIMEOUT,
            **kwargs,
        )
        self.nodes[node_id] = node
        async with asyncio.timeout(10):
            for other in self.nodes.values():
                await other.wait_for_peers(len(self.nodes) - 1)
        return node

    async def leave(self, node_id: str) -> None:
        await self.nodes.pop(node_id).close()

    async def hostile(self, target: str, frames: list[bytes]) -> None:
        # One link per frame. The node either refuses the frame and counts it, or, if
        # handling it fails, closes the link it came on: wait for whichever happens.
        node = self.nodes[target]
        for n, frame in enumerate(frames):
            ws = await open_raw(node.address)
            await authenticate(ws, self.secret, node=f"intruder-{n}")
            before = _dropped(node)
            await ws.send(frame)
            await self.until(partial(_answered, node, before, ws))
            await ws.close()

    async def until(self, predicate: Callable[[], bool], within: float = 10.0) -> None:
        deadline = time.monotonic() + within
        while not predicate():
            assert time.monotonic() < deadline, f"not within {within}s"
            await asyncio.sleep(0.005)

    async def close(self) -> None:
        for node in list(self.nodes.values()):
            await node.close()
        self.nodes.clear()


class ZenohHarness:
    """Zenoh nodes in this process over 127.0.0.1: peers each knowing only the previous
    node's endpoint, or (``via_router``) clients of one router."""

    def __init__(self, *, via_router: bool = False) -> None:
        self.name = "zenoh-client" if via_router else "zenoh-peer"
        self.via_router = via_router
        self.nodes: dict[str, ZenohNode] = {}
        self.router: ZenohRouter | None = None
        self.secret = b"conformance"

    async def add(self, node_id: str, **kwargs: Any) -> RoleActivator:
        if self.via_router:
            if self.router is None:
                self.router = await start_router(secret=self.secret, listen=["tcp/127.0.0.1:0"])
            connect, mode = self.router.endpoints, "client"
        else:
            last = list(self.nodes.values())[-1:]
            connect, mode = [n.address for n in last], "peer"
        node = await start_zenoh_node(
            node_id,
            secret=self.secret,
            connect=connect,
            mode=mode,  # type: ignore[arg-type]
            property_interval=INTERVAL,
            failure_timeout=FAILURE_TIMEOUT,
            **kwargs,
        )
        self.nodes[node_id] = node
        async with asyncio.timeout(10):
            for other in self.nodes.values():
                await other.wait_for_peers(len(self.nodes) - 1)
        return node

    async def leave(self, node_id: str) -> None:
        await self.nodes.pop(node_id).close()

    async def hostile(self, target: str, frames: list[bytes]) -> None:
        # An intruder that holds the secret puts each frame on the target's inbox key;
        # the target refuses each and counts it.
        node = self.nodes[target]
        connect = self.router.endpoints if self.router else [node.address]
        session = await open_fleet_session(self.secret, connect)
        try:
            for frame in frames:
                before = _dropped(node)
                session.put(f"objectplaces/default/to/{target}/intruder", frame)
                await self.until(lambda: _dropped(node) != before)  # noqa: B023
        finally:
            await asyncio.to_thread(session.close)

    async def until(self, predicate: Callable[[], bool], within: float = 10.0) -> None:
        deadline = time.monotonic() + within
        while not predicate():
            assert time.monotonic() < deadline, f"not within {within}s"
            await asyncio.sleep(0.005)

    async def close(self) -> None:
        for node in list(self.nodes.values()):
            await node.close()
        self.nodes.clear()
        if self.router is not None:
            await self.router.close()


def _dropped(node: RoleActivator) -> int:
    """Frames ``node`` has refused so far, whatever the reason."""
    return sum(v for k, v in node.stats().counters.items() if k.startswith("dropped"))


def _answered(node: RoleActivator, dropped_before: int, ws: Any) -> bool:
    """True once ``node`` counted a refused frame or closed the link ``ws``."""
    return _dropped(node) != dropped_before or ws.close_code is not None
