"""Embed an ObjectPlaces node in an asyncio application, over Zenoh.

```python
from objectplaces.security import Identity

node = await objectplaces.start_node(
    "agv-3", transport="zenoh", mode="client", connect=["tls/10.0.0.1:7447"],
    tls=Identity.from_pki("fleet-pki", "agv-3"),     # mutual TLS, its own keys only
)
node.update_node_property("position", (1.0, 2.0))   # the usual RoleActivator API
...
await node.close()                                   # leave the fleet
```

Plain ``tcp/`` links only when asked for by name, on loopback:
``start_zenoh_node("a", insecure=True, secret=SECRET)``.

The same ``NodeMachine`` and roles as on the WebSocket mesh; only the transport
differs (``objectplaces.transport.zenoh_transport``). docs/zenoh.md tells the keys,
membership by liveliness, security, and how to run a router for client-mode nodes.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Sequence

from objectplaces.core import codec
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.node import NodeConfig, NodeMachine
from objectplaces.network_node import NetworkNode
from objectplaces.runtime.aio import AsyncioRunner
from objectplaces.security.identity import Identity
from objectplaces.security.links import link_security
from objectplaces.transport.options import PeerStats
from objectplaces.transport.zenoh_alive import TOKEN_GRACE
from objectplaces.transport.zenoh_config import (
    Mode,
    ZenohOptions,
    check_protocol,
    endpoint_host,
    fleet_of,
    resolve_ports,
)
from objectplaces.transport.zenoh_transport import ZenohTransport
from tuplespace import TupleSpace

__all__ = ["ZenohNode", "ZenohRunner", "start_zenoh_node"]

log = logging.getLogger("objectplaces.zenoh")


class ZenohRunner(AsyncioRunner):
    """The asyncio runner, also taking raw frames: the machine's intake decodes them."""

    def deliver_raw(self, source: str, data: bytes) -> None:
        """Hand the machine one frame from ``source`` as it came off the wire."""
        if self.closed:
            return
        self.machine.receive(source, data, self.now())
        self.wake()

    def deliver_frames(self, frames: list[tuple[str, bytes]]) -> int:
        """Hand the machine frames that arrived together: one clock reading and one
        wake for all (per frame, those were a tenth of the loop's receiving work).

        Returns:
            How many frames failed (each logged; the others are handed on all the same).
        """
        if self.closed:
            return 0
        receive, now, failed = self.machine.receive, self.now(), 0
        for source, data in frames:
            try:
                receive(source, data, now)
            except Exception:
                # One frame's failure costs that frame, never the node.
                log.exception("node %s: a frame from %s failed", self.machine.node_id, source)
                failed += 1
        self.wake()
        return failed


class ZenohNode(NetworkNode):
    """A node on Zenoh: the ``RoleActivator`` API plus its membership.

    Made by ``start_node(..., transport="zenoh")``; ``await node.close()`` leaves.
    """

    def __init__(
        self,
        machine: NodeMachine,
        *,
        runner: ZenohRunner,
        transport: ZenohTransport,
        space: TupleSpace,
    ) -> None:
        super().__init__(machine, runner=runner, space=space)
        self._transport = transport

    @property
    def address(self) -> str:
        """The endpoints this node listens on ("" for a client)."""
        return self._transport.address

    def peers(self) -> list[str]:
        """Nodes of the fleet alive now (their liveliness token is up), sorted."""
        return self._transport.peers()

    def peer_stats(self) -> dict[str, PeerStats]:
        """Per-peer link counters: none on Zenoh, which keeps the links (see counters)."""
        return {}

    def twin_up_for(self) -> float | None:
        """Seconds another run with this node's id has held its token (None: none does).
        An earlier run of this process holds it at most the lease after it died."""
        return self._transport.membership.twin_up_for()

    def refusals(self) -> dict[str, str]:
        """Why nodes of another fleet tag are not heard, by node."""
        return dict(self._transport.membership.refusals)

    def transport_counters(self) -> dict[str, int]:
        """Node-wide transport counters (frames and bytes in and out, drops by reason)."""
        return dict(sorted(self._transport.counters.items()))

    async def links_changed(self) -> None:
        """Wait until a node appears or goes."""
        await self._transport.links_changed()

    async def close(self) -> None:
        """Leave: stop our sessions, drop our roles, tell the fleet, close the session."""
        if not self._mark_closed("closed", settled=False):
            return
        runner = self._runner
        self.machine.leave(runner.now())
        runner.drain()
        runner.close()
        await self._transport.close()
        self._settle_closed()

    def __repr__(self) -> str:
        return f"<ZenohNode {self.node_id!r} at {self.address or 'client'}>"


async def start_zenoh_node(
    node_id: str,
    *,
    tls: Identity | None = None,
    insecure: bool = False,
    secret: bytes | None = None,
    listen: Sequence[str] | None = None,
    connect: Sequence[str] = (),
    mode: Mode = "peer",
    fleet: str | None = None,
    lease: float = 10.0,
    token_grace: float = TOKEN_GRACE,
    interest_radius: float | None = None,
    property_interval: float | None = 1.0,
    beat_interval: float | None = None,
    rest_beat_interval: float | None = None,
    failure_timeout: float | None = None,
    cell_size: float = 25.0,
    retransmit_timeout: float = 0.2,
    max_frame: int | None = None,
    poll_interval: float | None = None,
    space: TupleSpace | None = None,
    tag: str = "",
) -> ZenohNode:
    """Start a node on Zenoh and return its ``RoleActivator``.

    Args:
        node_id: unique in the fleet; with ``tls``, the id its certificate names.
        tls: the node's certified identity (``Identity.from_pki``): every link is
            ``tls/`` with mutual TLS, the node puts only on its own keys and reads only
            its own inbox (the router's, or a peer's, access control), and what a
            revoked member sends is dropped.
        insecure: plain ``tcp/`` links instead, proven by ``secret``; loopback only.
        secret: with ``insecure``, shared by every node of the fleet (32 bytes or more;
            becomes Zenoh credentials, never sent); with ``tls``, a second factor.
        listen: endpoints to listen on (peers; port 0 picks a free one); by default
            ``tls/127.0.0.1:0`` (``tcp/`` when insecure).
        connect: endpoints of peers or a router to connect to.
        mode: ``peer`` or ``client`` (a client needs a router in ``connect``).
        fleet: the fleet's name (its key prefix); by default the certificate's fleet
            (``default`` when insecure).
        lease: a silent node's links close after this long (and it leaves every
            group, if ``failure_timeout`` has not made it leave before).
        token_grace: a node whose liveliness token goes leaves its groups only if the
            token is not back this long after (0: at once; docs/zenoh.md).
        interest_radius: scoped dissemination radius (None: hear every node).
        property_interval: republish properties this often (None: never).
        beat_interval: send a liveness beat (a few bytes) after this long without a
            publication (None: no beats; ``property_interval`` is the heartbeat). With
            beats, ``property_interval`` can be long (docs/protocol.md §2).
        rest_beat_interval: the beat interval of a node at rest (``set_at_rest``), and
            the longest this node waits for a resting peer's beats (None: no rest;
            ``NodeConfig.rest_beat_interval``).
        failure_timeout: a node not heard this long leaves every group (None: three
            liveness intervals, the shorter of beats and republications); a node whose
            process dies leaves before, by liveliness.
        cell_size: grid cell side for scoped dissemination and the spatial index.
        retransmit_timeout: first retransmission delay of session channel frames.
        max_frame: largest frame accepted, in bytes.
        poll_interval: hand received data on every this many seconds, together, instead
            of each frame at once (None): fewer wake-ups for a busy process, frames
            delayed up to this long (docs/zenoh.md, "Threads").
        space: the node's tuplespace (a new one by default).
        tag: what every member of the fleet shares, e.g. the digest of the layout its
            vehicles drive (in the node's liveliness token): what a node of another tag
            sends is dropped, and ``refusals`` says why, naming both tags.

    Raises:
        LocalProtocolError: a bad argument; neither ``tls`` nor ``insecure``; a plain
            link off loopback; an endpoint of the other protocol.
        CredentialError: the identity names another id or a role that is no member,
            its PKI folder holds no ``members.json``, or the secret is too short.
        OSError: Zenoh could not open the session (an endpoint cannot be bound ...).
    """
    if interest_radius is not None and not interest_radius > 0:
        raise LocalProtocolError(f"interest_radius must be > 0, got {interest_radius!r}")
    if mode not in ("peer", "client"):
        raise LocalProtocolError(f"mode must be 'peer' or 'client', got {mode!r}")
    if isinstance(listen, str) or isinstance(connect, str):
        raise LocalProtocolError("listen and connect must be lists of endpoints")
    protocol = "tcp" if tls is None else "tls"
    if listen is None:
        listen = (f"{protocol}/127.0.0.1:0",)
    listen = tuple(listen) if mode == "peer" else ()
    ZenohOptions(mode=mode, listen=listen, connect=tuple(connect))  # checks the endpoints
    hosts = [endpoint_host(e) for e in (*listen, *connect)]
    link_security(node_id, tls=tls, secret=secret, insecure=insecure, hosts=hosts)
    check_protocol((*listen, *connect), protocol)
    options = ZenohOptions(
        mode=mode,
        listen=resolve_ports(listen),
        connect=tuple(connect),
        fleet=fleet_of(tls, fleet),
        lease=lease,
        token_grace=token_grace,
        max_frame=codec.DEFAULT_MAX_FRAME if max_frame is None else max_frame,
        poll_interval=poll_interval,
    )
    loop = asyncio.get_running_loop()
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
    transport = ZenohTransport(
        node_id, options=options, incarnation=time.time_ns(), tls=tls, secret=secret, tag=tag
    )
    runner = ZenohRunner(machine, transport.transmit)
    transport.attach(runner)
    await transport.open()
    node = ZenohNode(machine, runner=runner, transport=transport, space=space)
    runner.wake()
    return node
