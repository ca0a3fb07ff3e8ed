"""Embed an ObjectPlaces node in an asyncio application, linked to its peers over WebSockets.

```python
from objectplaces.security import Identity

node = await objectplaces.start_node(
    "agv-3", listen="10.0.0.3:7003", join=["10.0.0.1:7001"],
    tls=Identity.from_pki("fleet-pki", "agv-3"),     # wss:// with mutual TLS
)
node.update_node_property("position", (1.0, 2.0))   # the usual RoleActivator API
...
await node.close()                                   # leave the mesh
```

Plain ``ws://`` links only when asked for by name, on loopback:
``start_node("a", listen="127.0.0.1:0", insecure=True, secret=SECRET)``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal, overload

from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.node import NodeConfig, NodeMachine
from objectplaces.network_node import NetworkNode
from objectplaces.runtime.aio import AsyncioRunner
from objectplaces.security.identity import Identity
from objectplaces.security.links import link_security
from objectplaces.transport.mesh_frames import MAX_TAG
from objectplaces.transport.options import MeshOptions, PeerStats
from objectplaces.transport.websocket import WebSocketMesh
from tuplespace import TupleSpace

if TYPE_CHECKING:
    from objectplaces.zenoh_node import ZenohNode

__all__ = ["MeshNode", "MeshOptions", "PeerStats", "start_mesh_node", "start_node"]

log = logging.getLogger("objectplaces.mesh")


class MeshNode(NetworkNode):
    """A node on the WebSocket mesh: the ``RoleActivator`` API plus its links.

    Made by ``start_node``; ``await node.close()`` leaves the mesh.
    """

    def __init__(
        self,
        machine: NodeMachine,
        *,
        runner: AsyncioRunner,
        mesh: WebSocketMesh,
        space: TupleSpace,
    ) -> None:
        super().__init__(machine, runner=runner, space=space)
        self._mesh = mesh
        self._task: asyncio.Task[None] | None = None
        self._close_called = False

    @property
    def address(self) -> str:
        """``host:port`` this node listens on."""
        return self._mesh.address

    def peers(self) -> list[str]:
        """Ids of the peers linked to this node now, sorted."""
        return self._mesh.peers()

    def peer_stats(self) -> dict[str, PeerStats]:
        """Per-peer counters (messages, bytes in/out, drops, reconnects), by peer id."""
        return self._mesh.peer_stats()

    def refusals(self) -> dict[str, str]:
        """Why peers refused this node's links lately, by the address dialed (another
        fleet tag, another certificate id, a revoked certificate ...)."""
        return self._mesh.refusals()

    def transport_counters(self) -> dict[str, int]:
        """Node-wide transport counters (refused links by reason, dropped frames ...)."""
        return dict(sorted(self._mesh.counters.items()))

    async def links_changed(self) -> None:
        """Wait until a link to a peer comes up or goes down."""
        await self._mesh.links_changed()

    def _start(self) -> None:
        self._task = asyncio.create_task(self._mesh.run(), name=f"objectplaces-node-{self.node_id}")
        self._task.add_done_callback(self._on_mesh_done)
        self._runner.wake()

    def _on_mesh_done(self, task: asyncio.Task[None]) -> None:
        """However the mesh stopped, the node is closed and says why, once."""
        error: BaseException | None = None
        if task.cancelled():
            reason = "the mesh was cancelled"
        elif (error := task.exception()) is not None:
            reason = f"the mesh failed: {_describe(error)}"
        else:
            reason = "the mesh stopped"
        self._mesh.abort()  # a task cancelled before it ran never cleaned up
        if self._mark_closed(reason):
            self._runner.close()
            log.error("node %s: %s; the node is closed", self.node_id, reason, exc_info=error)

    async def close(self) -> None:
        """Leave the mesh: stop our sessions, drop our roles, tell the peers, close links.

        Also releases what is left after the mesh stopped by itself (see ``closed``).
        """
        if self._close_called:
            return
        self._close_called = True
        runner = self._runner
        if self._mark_closed("closed"):
            self.machine.leave(runner.now())
            runner.drain()
        runner.close()
        await self._mesh.close()
        task = self._task
        if task is not None and not task.done():
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task

    def __repr__(self) -> str:
        return f"<MeshNode {self.node_id!r} at {self.address}>"


def _describe(exc: BaseException) -> str:
    """Name the first real error inside ``exc`` (task groups wrap theirs)."""
    while isinstance(exc, BaseExceptionGroup) and exc.exceptions:
        exc = exc.exceptions[0]
    return f"{type(exc).__name__}: {exc}"


@overload
async def start_node(
    node_id: str, *, transport: Literal["websocket"] = ..., **kwargs: Any
) -> MeshNode: ...


@overload
async def start_node(node_id: str, *, transport: Literal["zenoh"], **kwargs: Any) -> ZenohNode: ...


async def start_node(
    node_id: str, *, transport: str = "websocket", **kwargs: Any
) -> MeshNode | ZenohNode:
    """Start a node on the WebSocket mesh (the default) or, with ``transport="zenoh"``,
    on Zenoh, and return its ``RoleActivator``.

    The keyword arguments are those of ``start_mesh_node`` or of
    ``objectplaces.zenoh_node.start_zenoh_node`` (``listen``, ``connect``, ``mode`` ...).

    Raises:
        LocalProtocolError: a bad argument or an unknown transport.
        OSError: the node cannot listen or connect.
    """
    if transport == "websocket":
        return await start_mesh_node(node_id, **kwargs)
    if transport == "zenoh":
        from objectplaces.zenoh_node import start_zenoh_node

        return await start_zenoh_node(node_id, **kwargs)
    raise LocalProtocolError(f"transport must be 'websocket' or 'zenoh', got {transport!r}")


async def start_mesh_node(
    node_id: str,
    *,
    listen: str = "127.0.0.1:0",
    join: Sequence[str] = (),
    tls: Identity | None = None,
    insecure: bool = False,
    secret: bytes | None = None,
    interest_radius: float | None = None,
    property_interval: float | None = 1.0,
    beat_interval: float | None = None,
    rest_beat_interval: float | None = None,
    failure_timeout: float | None = None,
    cell_size: float = 25.0,
    retransmit_timeout: float = 0.2,
    options: MeshOptions | None = None,
    space: TupleSpace | None = None,
    tag: str = "",
) -> MeshNode:
    """Start a node on the WebSocket mesh and return its ``RoleActivator``.

    Args:
        node_id: unique in the mesh.
        listen: ``host:port`` to listen on (loopback by default; port 0 picks one).
        join: ``host:port`` of one or more nodes already in the mesh.
        tls: the node's certified identity (``Identity.from_pki``): every link is
            ``wss://`` with mutual TLS, and a peer's id is its certificate's.
        insecure: plain ``ws://`` links instead, proven by ``secret``; loopback only.
        secret: with ``insecure``, shared by every node (32 bytes or more; proves each
            link, never sent); with ``tls``, an optional second factor.
        interest_radius: scoped dissemination radius (None: hear every node).
        property_interval: republish properties this often (None: never); the heartbeat
            unless ``beat_interval`` is set.
        beat_interval: send a liveness beat (a few bytes) after this long without a
            publication (None: no beats). With beats, ``property_interval`` can be long
            (docs/protocol.md §2).
        rest_beat_interval: the beat interval of a node at rest (``set_at_rest``), and
            the longest this node waits for a resting peer's beats (None: no rest;
            ``NodeConfig.rest_beat_interval``).
        failure_timeout: a node not heard this long leaves every group (None: three
            liveness intervals, the shorter of beats and republications).
        cell_size: grid cell side for scoped dissemination and the spatial index.
        retransmit_timeout: first retransmission delay of session channel frames.
        options: transport limits and timings (flood limit, frame size, backoff ...).
        space: the node's tuplespace (a new one by default).
        tag: what every member of the fleet shares, e.g. the digest of the layout its
            vehicles drive: a peer with another tag is refused when it links, and both
            sides say why (``refusals``), naming both tags.

    Raises:
        LocalProtocolError: a bad argument; neither ``tls`` nor ``insecure``; a plain
            link off loopback.
        CredentialError: the identity or the secret cannot be used (a subclass).
        OSError: ``listen`` cannot be bound.
    """
    if interest_radius is not None and not interest_radius > 0:
        raise LocalProtocolError(f"interest_radius must be > 0, got {interest_radius!r}")
    if isinstance(join, str):
        raise LocalProtocolError(f"join must be a list of addresses, got {join!r}")
    if not isinstance(tag, str) or len(tag) > MAX_TAG:
        raise LocalProtocolError(f"tag must be text of at most {MAX_TAG} characters, got {tag!r}")
    hosts = [address.rpartition(":")[0] for address in (listen, *join)]
    security = link_security(node_id, tls=tls, secret=secret, insecure=insecure, hosts=hosts)
    loop = asyncio.get_running_loop()
    options = options or MeshOptions()
    config = NodeConfig(
        property_interval=property_interval,
        beat_interval=beat_interval,
        rest_beat_interval=rest_beat_interval,
        failure_timeout=failure_timeout,
        interest_radius=interest_radius,
        cell_size=cell_size,
        retransmit_timeout=retransmit_timeout,
        max_frame=options.max_frame,
    )
    space = space if space is not None else TupleSpace(clock=loop.time)
    machine = NodeMachine(node_id, now=loop.time(), config=config, space=space)
    mesh = WebSocketMesh(
        node_id,
        security=security,
        listen=listen,
        seeds=join,
        options=options,
        incarnation=time.time_ns(),
        tag=tag,
    )
    runner = AsyncioRunner(machine, mesh.transmit)
    mesh.attach(runner)
    await mesh.open()
    node = MeshNode(machine, runner=runner, mesh=mesh, space=space)
    node._start()
    return node
