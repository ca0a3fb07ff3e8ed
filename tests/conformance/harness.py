"""Ways to run the same scenario: the simulated network, and mesh or Zenoh nodes (peers,
or clients of a router) each in its own process on 127.0.0.1.

A scenario only adds nodes, sets their properties, starts and stops sessions with a
``Recorder`` initiator, lets nodes play ``Ticker`` participants, lets nodes leave or kills
them, and waits for conditions on what the nodes see; it never knows which transport
carries it, nor whether the nodes live in this process.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import secrets
import tempfile
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from pathlib import Path
from typing import Any, ClassVar, Protocol

from objectplaces import RoleActivator
from objectplaces.groups import GroupDefinition
from objectplaces.sim import SimulatedNetwork
from tests.conformance.proxy import LineProcess, PuppetNode, PuppetPool, poll
from tests.conformance.roles import Recorder, RecorderLog, Ticker
from tests.mesh.rawpeer import authenticate, open_raw
from tests.zenoh.intruder import open_fleet_session

INTERVAL = 0.2
FAILURE_TIMEOUT = 1.0


class TickerLog(Protocol):
    """What a scenario reads of a ``Ticker``."""

    log: list[str]


class ScenarioNode(Protocol):
    """What a scenario does with a node."""

    @property
    def node_id(self) -> str:
        """The node's id."""
        ...

    def update_node_property(self, name: str, value: Any) -> None:
        """Set one of the node's properties."""
        ...

    def view(self) -> Mapping[str, Mapping[str, Any]]:
        """What the node knows of the others' properties."""
        ...

    def state_counts(self) -> Mapping[str, int]:
        """``machine.state_counts()`` of the node."""
        ...

    def serve(self, role: str) -> Sequence[TickerLog]:
        """Play ``role`` with a new ``Ticker`` per activation; the tickers, live."""
        ...

    async def start_interaction(self, definition: GroupDefinition, role: str) -> RecorderLog:
        """Start a session whose initiator is a ``Recorder``; returns it (or its mirror)."""
        ...

    def stop_interaction(self, recorder: RecorderLog) -> None:
        """Stop a session this node started."""
        ...


class Harness(Protocol):
    """What the scenarios need from a network."""

    name: str

    async def add(self, node_id: str, **kwargs: Any) -> ScenarioNode:
        """Add a node; it is linked with every other node when this returns."""
        ...

    async def leave(self, node_id: str) -> None:
        """Let a node leave gracefully; its roles' last callbacks are seen."""
        ...

    async def kill(self, node_id: str) -> None:
        """Crash a node: it stops at once and says nothing more."""
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


class LocalNode:
    """A node of the simulated network behind the scenarios' interface."""

    def __init__(self, activator: RoleActivator) -> None:
        self.activator = activator

    @property
    def node_id(self) -> str:
        """The node's id."""
        return self.activator.node_id

    def update_node_property(self, name: str, value: Any) -> None:
        """Set one of the node's properties."""
        self.activator.update_node_property(name, value)

    def view(self) -> Mapping[str, Mapping[str, Any]]:
        """The node's view."""
        return self.activator.view()

    def state_counts(self) -> Mapping[str, int]:
        """``machine.state_counts()``."""
        return self.activator.machine.state_counts()

    def serve(self, role: str) -> list[Ticker]:
        """Play ``role`` with a new ``Ticker`` per activation."""
        tickers: list[Ticker] = []

        def make() -> Ticker:
            tickers.append(Ticker())
            return tickers[-1]

        self.activator.set_participant_factory(role, make)
        return tickers

    async def start_interaction(self, definition: GroupDefinition, role: str) -> Recorder:
        """Start a session with a ``Recorder``."""
        recorder = Recorder()
        self.activator.start_interaction(recorder, definition, role)
        return recorder

    def stop_interaction(self, recorder: RecorderLog) -> None:
        """Stop a session this node started."""
        self.activator.stop_interaction(recorder.session_id)


class SimHarness:
    """The seeded simulated network, in virtual time."""

    name = "sim"

    def __init__(self, _pool: PuppetPool | None = None) -> None:
        self.net = SimulatedNetwork(
            seed=4, delay=0.002, jitter=0.001, property_interval=INTERVAL,
            failure_timeout=FAILURE_TIMEOUT,
        )  # fmt: skip

    async def add(self, node_id: str, **kwargs: Any) -> LocalNode:
        node = self.net.add_node(node_id, **kwargs)
        self.net.run_for(0.01)
        return LocalNode(node)

    async def leave(self, node_id: str) -> None:
        self.net.leave(node_id)

    async def kill(self, node_id: str) -> None:
        self.net.remove_node(node_id)

    async def hostile(self, target: str, frames: list[bytes]) -> None:
        for frame in frames:
            self.net.inject("intruder", target, frame)
        self.net.run_for(0.01)

    async def until(self, predicate: Callable[[], bool], within: float = 10.0) -> None:
        assert self.net.run_until(predicate, within), f"not within {within}s of virtual time"

    async def close(self) -> None:
        pass


class ProcessHarness:
    """Nodes each in a puppet process of ``pool``, on ``transport`` over 127.0.0.1."""

    name: str
    transport: ClassVar[str]

    def __init__(self, pool: PuppetPool) -> None:
        self.pool = pool
        self.nodes: dict[str, PuppetNode] = {}
        self.secret = secrets.token_hex(32).encode()  # no link to another scenario's nodes

    async def links(self) -> dict[str, Any]:
        """How the next node finds the others (``start_node`` keywords)."""
        raise NotImplementedError

    async def add(self, node_id: str, **kwargs: Any) -> PuppetNode:
        links = await self.links()
        node = self.pool.take()
        node.start_node(
            node_id, self.transport, self.secret, property_interval=INTERVAL,
            failure_timeout=FAILURE_TIMEOUT, **links, **kwargs,
        )  # fmt: skip
        self.nodes[node_id] = node
        # Bounds for start-up on a loaded machine, not figures of the protocol.
        await self.until(lambda: node.address is not None, within=30.0)
        linked = len(self.nodes) - 1
        await self.until(
            lambda: all(len(n.peers) >= linked for n in self.nodes.values()), within=20.0
        )
        return node

    async def leave(self, node_id: str) -> None:
        node = self.nodes.pop(node_id)
        node.process.send(cmd="leave")
        await poll([node], lambda: node.closed, within=10)
        self.pool.give_back(node)

    async def kill(self, node_id: str) -> None:
        node = self.nodes.pop(node_id)
        node.killed = True
        node.process.kill()
        self.pool.retire(node)

    async def until(self, predicate: Callable[[], bool], within: float = 10.0) -> None:
        await poll(list(self.nodes.values()), predicate, within)

    async def close(self) -> None:
        nodes = list(self.nodes.values())
        self.nodes.clear()
        for node in nodes:
            with contextlib.suppress(OSError):
                node.process.send(cmd="leave")
        # A node that does not leave in time, or says something amiss meanwhile (after
        # a failed scenario), is not used again: give_back retires it.
        with contextlib.suppress(AssertionError):
            await poll(nodes, lambda: all(n.closed for n in nodes), within=10)
        for node in nodes:
            self.pool.give_back(node)


class MeshProcesses(ProcessHarness):
    """Mesh nodes in their own processes; each joins through the first one."""

    name = "mesh"
    transport = "websocket"

    async def links(self) -> dict[str, Any]:
        first = next(iter(self.nodes.values()), None)
        return {"join": [first.address] if first else []}

    async def hostile(self, target: str, frames: list[bytes]) -> None:
        # One link per frame. The node either refuses the frame and counts it, or, if
        # handling it fails, closes the link it came on: wait for whichever happens.
        node = self.nodes[target]
        assert node.address is not None
        for n, frame in enumerate(frames):
            ws = await open_raw(node.address)
            await authenticate(ws, self.secret, node=f"intruder-{n}")
            before = node.dropped
            await ws.send(frame)
            await self.until(partial(_answered, node, before, ws))
            await ws.close()


class ZenohProcesses(ProcessHarness):
    """Zenoh nodes in their own processes: peers each knowing only the previous node's
    endpoint, or (``via_router``) clients of a router process."""

    transport = "zenoh"

    def __init__(self, pool: PuppetPool, *, via_router: bool = False) -> None:
        super().__init__(pool)
        self.name = "zenoh-client" if via_router else "zenoh-peer"
        self.router: LineProcess | None = None
        self.endpoints: list[str] = []
        self.secret_dir = tempfile.TemporaryDirectory(prefix="conformance-")
        if via_router:  # starts while the first node's process is taken from the pool
            secret_file = Path(self.secret_dir.name) / "secret"
            secret_file.write_bytes(self.secret)
            os.chmod(secret_file, 0o600)
            self.router = LineProcess(
                ["-m", "objectplaces.router_cli", "--listen", "tcp/127.0.0.1:0",
                 "--insecure", "--secret-file", str(secret_file), "--run-seconds", "120"]
            )  # fmt: skip

    async def _router_endpoints(self) -> list[str]:
        router = self.router
        assert router is not None
        while not self.endpoints:
            await poll([], lambda: bool(router.events) or not router.running, within=10)
            assert router.events, f"the router did not start: {router.describe()}"
            event = router.events.popleft()
            assert event["event"] == "ready", event
            self.endpoints = list(event["endpoints"])
        return self.endpoints

    async def links(self) -> dict[str, Any]:
        if self.router is not None:
            return {"connect": await self._router_endpoints(), "mode": "client"}
        last = list(self.nodes.values())[-1:]
        return {"connect": [n.address for n in last], "mode": "peer"}

    async def hostile(self, target: str, frames: list[bytes]) -> None:
        # An intruder that holds the secret puts each frame on the target's inbox key;
        # the target refuses each and counts it.
        node = self.nodes[target]
        connect = self.endpoints if self.router else [str(node.address)]
        session = await open_fleet_session(self.secret, connect)
        try:
            for frame in frames:
                before = node.dropped
                session.put(f"objectplaces/default/to/{target}/intruder", frame)
                await self.until(lambda: node.dropped != before)  # noqa: B023
        finally:
            await asyncio.to_thread(session.close)

    async def close(self) -> None:
        await super().close()
        if self.router is not None:
            self.router.kill()
            await asyncio.to_thread(self.router.reap, 10)
        self.secret_dir.cleanup()


def _answered(node: PuppetNode, dropped_before: int, ws: Any) -> bool:
    """True once ``node`` counted a refused frame or closed the link ``ws``."""
    return node.dropped != dropped_before or ws.close_code is not None
