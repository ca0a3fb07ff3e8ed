"""The WebSocket mesh: every node linked to every other, over authenticated WebSockets.

Each node listens on ``host:port`` and dials its seeds; peers tell each other whom they
are linked to (gossip), so the mesh becomes full without anyone listing every peer. One
link carries both directions between a pair of nodes; when both dial at once, the link
dialed by the node with the smaller id stays. For a pair that is not linked, the node
with the smaller id dials (and a node always dials its seeds), with bounded exponential
backoff, so a restarted node is found again by whoever knew it.

Routing (the transport decides nothing about the protocol, it only carries outputs):
``Send`` goes to its target's link, ``Broadcast`` to every link, ``Publish`` to the peers
whose declared subscription covers one of the cells. Subscriptions are declared to every
peer (there is no router in a mesh); when a peer newly subscribes to the cell we last
published in, or declares a full subscription, the machine sends it our properties.

Every link is authenticated (``mesh_frames``: challenge/response over both nonces) and
policed: a text frame, a malformed or unknown frame, one over ``max_frame`` bytes, or more
frames than the flood limit allows closes that link with a reason; the node and its other
links carry on.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import logging
import os
import random
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, Final

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidURI

from objectplaces.core import codec
from objectplaces.core.errors import DecodeError, LocalProtocolError
from objectplaces.core.events import Broadcast, Output, Publish, Send, Subscribe
from objectplaces.runtime.aio import AsyncioRunner
from objectplaces.transport.mesh_frames import (
    BATCH,
    NONCE_SIZE,
    Auth,
    Batch,
    Gossip,
    Hello,
    PeerAddress,
    SubscribeCells,
    VersionMismatch,
    decode_transport,
    encode_auth,
    encode_batch,
    encode_gossip,
    encode_hello,
    encode_subscribe,
    handshake_macs,
    parse_address,
)

__all__ = ["CloseCode", "MeshOptions", "PeerStats", "TokenBucket", "WebSocketMesh"]

log = logging.getLogger("objectplaces.mesh")

Cell = tuple[int, int]
Connection = ServerConnection | ClientConnection
_LEAVING: Final = "leaving"
_BATCH_BYTES: Final = 64 * 1024
_BATCH_FRAMES: Final = 512


class CloseCode:
    """WebSocket close codes the mesh uses (RFC 6455 section 7.4.1)."""

    NORMAL: Final = 1000
    GOING_AWAY: Final = 1001
    PROTOCOL_ERROR: Final = 1002
    UNSUPPORTED_DATA: Final = 1003
    POLICY_VIOLATION: Final = 1008
    MESSAGE_TOO_BIG: Final = 1009
    TRY_AGAIN_LATER: Final = 1013


@dataclass(frozen=True, slots=True)
class MeshOptions:
    """Limits and timings of the mesh; durations in seconds.

    Attributes:
        max_frame: largest frame accepted, in bytes (also websockets' ``max_size``).
        flood_rate: frames per second a peer may send on average.
        flood_burst: frames a peer may send at once above that rate.
        queue_size: frames queued for one peer before new ones are dropped.
        handshake_timeout: time allowed for connecting and authenticating.
        backoff_initial: first delay before redialing a lost peer.
        backoff_max: longest delay between two dials of one peer.
        forget_after: a peer unreachable this long is no longer dialed (seeds always are).
        gossip_interval: how often every peer is told our whole peer list.
        max_links: inbound and outbound links at most (more are refused).
        close_timeout: time allowed for the closing handshake of a link.
    """

    max_frame: int = codec.DEFAULT_MAX_FRAME
    flood_rate: float = 100_000.0
    flood_burst: float = 20_000.0
    queue_size: int = 8192
    handshake_timeout: float = 5.0
    backoff_initial: float = 0.05
    backoff_max: float = 2.0
    forget_after: float = 30.0
    gossip_interval: float = 2.0
    max_links: int = 512
    close_timeout: float = 1.0

    def __post_init__(self) -> None:
        for name in ("flood_rate", "flood_burst", "handshake_timeout", "backoff_initial"):
            if not getattr(self, name) > 0:
                raise LocalProtocolError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if self.max_frame < 64 or self.queue_size < 1 or self.max_links < 1:
            raise LocalProtocolError(f"limits too small in {self!r}")


@dataclass(frozen=True, slots=True)
class PeerStats:
    """Traffic with one peer since this node started.

    Attributes:
        address: where the peer listens.
        connected: whether a link is up now.
        links: links established so far.
        reconnects: links established while no other link to the peer was up, after the first.
        messages_in: frames received.
        bytes_in: their payload bytes.
        messages_out: frames sent.
        bytes_out: their payload bytes.
        drops: frames for this peer dropped (no link, or its queue full).
        last_close: why the last link closed ("" while none has).
    """

    address: str
    connected: bool
    links: int
    reconnects: int
    messages_in: int
    bytes_in: int
    messages_out: int
    bytes_out: int
    drops: int
    last_close: str


@dataclass(slots=True)
class _Counters:
    address: str = ""
    links: int = 0
    reconnects: int = 0
    messages_in: int = 0
    bytes_in: int = 0
    messages_out: int = 0
    bytes_out: int = 0
    drops: int = 0
    last_close: str = ""


class TokenBucket:
    """Allows ``rate`` events per second on average, ``burst`` at once.

    Args:
        rate: tokens added per second.
        burst: the bucket's capacity (and its initial content).
        now: the time at creation.
    """

    __slots__ = ("_at", "_burst", "_rate", "_tokens")

    def __init__(self, rate: float, burst: float, now: float) -> None:
        self._rate = rate
        self._burst = burst
        self._tokens = burst
        self._at = now

    def take(self, now: float) -> bool:
        """Spend one token; False when the bucket is empty."""
        tokens = self._tokens
        if tokens < 1.0:
            tokens = min(self._burst, tokens + (now - self._at) * self._rate)
            self._at = now
            if tokens < 1.0:
                self._tokens = tokens
                return False
        self._tokens = tokens - 1.0
        return True


@dataclass(slots=True)
class _Known:
    """What the node knows of one peer (or, keyed ``@address``, of a seed not yet reached)."""

    address: str
    incarnation: int = 0
    seed: bool = False
    gone: bool = False
    attempts: int = 0
    next_dial: float = 0.0
    dialing: bool = False
    last_seen: float = 0.0


@dataclass(eq=False, slots=True)
class _Link:
    peer: str
    address: str
    incarnation: int
    ws: Connection
    dialer: str
    queue: asyncio.Queue[bytes | None]
    bucket: TokenBucket
    counters: _Counters
    established: float = 0.0
    retired: bool = False
    close_reason: str = field(default="")


class _Refused(Exception):
    """A handshake failed; the link is closed with ``code`` and ``reason``."""

    def __init__(self, code: int, reason: str) -> None:
        super().__init__(reason)
        self.code = code
        self.reason = reason


def _short(reason: str) -> str:
    """Fit a close reason in the 123 bytes a close frame allows."""
    encoded = reason.encode()
    return reason if len(encoded) <= 120 else encoded[:117].decode(errors="ignore") + "..."


class WebSocketMesh:
    """One node's links to its peers.

    Args:
        node_id: this node's id.
        secret: the shared secret every link proves.
        listen: ``host:port`` to listen on (port 0 picks a free one).
        seeds: ``host:port`` of nodes to join through.
        options: limits and timings.
        incarnation: distinguishes this run of the node from earlier ones (larger is newer).
    """

    def __init__(
        self,
        node_id: str,
        *,
        secret: bytes,
        listen: str = "127.0.0.1:0",
        seeds: Iterable[str] = (),
        options: MeshOptions | None = None,
        incarnation: int,
    ) -> None:
        if not isinstance(secret, bytes) or not secret:
            raise LocalProtocolError("secret must be non-empty bytes")
        try:
            self._host, self._port = parse_address(listen)
            seed_list = [f"{h}:{p}" for h, p in map(parse_address, seeds)]
        except DecodeError as exc:
            raise LocalProtocolError(str(exc)) from exc
        self.node_id = node_id
        self.options = options or MeshOptions()
        self.incarnation = incarnation
        self.counters: dict[str, int] = {}
        self._secret = secret
        self._runner: AsyncioRunner | None = None
        self._server: Server | None = None
        self._tg: asyncio.TaskGroup | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._links: dict[str, _Link] = {}
        self._all_links: set[_Link] = set()
        self._known: dict[str, _Known] = {f"@{a}": _Known(a, seed=True) for a in seed_list}
        self._linked_incarnation: dict[str, int] = {}
        self._peer_counters: dict[str, _Counters] = {}
        self._own_subscription: frozenset[Cell] | None = None
        self._subscribed = False
        self._peer_subs: dict[str, frozenset[Cell] | None] = {}
        self._cell_subs: dict[Cell, dict[str, None]] = {}
        self._wildcard: dict[str, None] = {}
        self._published_cell: Cell | None = None
        self._changed = asyncio.Event()
        self._links_event = asyncio.Event()
        self._closing = False
        self._rng = random.Random()
        self.address = listen

    # ------------------------------------------------------------------ lifecycle

    def attach(self, runner: AsyncioRunner) -> None:
        """Connect the runner whose machine this mesh carries."""
        self._runner = runner

    async def open(self) -> None:
        """Start listening; ``address`` then holds the real port.

        Raises:
            OSError: the address cannot be bound.
        """
        self._loop = asyncio.get_running_loop()
        self._server = await serve(
            self._accept,
            self._host,
            self._port,
            compression=None,
            max_size=self.options.max_frame,
            max_queue=64,
            open_timeout=self.options.handshake_timeout,
            close_timeout=self.options.close_timeout,
            server_header=None,
            logger=logging.getLogger("objectplaces.mesh.websockets"),
        )
        port = self._server.sockets[0].getsockname()[1]
        host = self._host if ":" not in self._host else f"[{self._host}]"
        self.address = f"{host}:{port}"

    async def run(self) -> None:
        """Dial, redial and gossip until cancelled; links run inside this task group."""
        assert self._server is not None, "open() first"
        async with asyncio.TaskGroup() as tg:
            self._tg = tg
            await self._supervise(tg)

    async def close(self) -> None:
        """Flush what is queued for every peer, then close every link and stop listening."""
        self._closing = True
        for link in list(self._all_links):
            with contextlib.suppress(asyncio.QueueFull):
                link.queue.put_nowait(None)
        if self._all_links:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self.options.close_timeout):
                    while self._all_links:
                        await self.links_changed()
        if self._server is not None:
            self._server.close()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self.options.close_timeout):
                    await self._server.wait_closed()
        self._changed.set()

    # ------------------------------------------------------------------ introspection

    async def links_changed(self) -> None:
        """Wait until a link comes up or goes down."""
        await self._links_event.wait()

    def _signal_links(self) -> None:
        self._links_event.set()
        self._links_event = asyncio.Event()

    def peers(self) -> list[str]:
        """Peers with a link up now, sorted."""
        return sorted(self._links)

    def peer_stats(self) -> dict[str, PeerStats]:
        """Traffic counters of every peer this node has linked with, by id."""
        out = {}
        for peer in sorted(self._peer_counters):
            c = self._peer_counters[peer]
            out[peer] = PeerStats(
                c.address,
                peer in self._links,
                c.links,
                c.reconnects,
                c.messages_in,
                c.bytes_in,
                c.messages_out,
                c.bytes_out,
                c.drops,
                c.last_close,
            )
        return out

    def _count(self, name: str) -> None:
        self.counters[name] = self.counters.get(name, 0) + 1

    # ------------------------------------------------------------------ outputs

    def transmit(self, output: Output) -> int:
        """Carry one output of the machine (never blocks; a full queue drops the frame).

        Returns:
            How many frames were queued for the wire.
        """
        match output:
            case Send(target, data, _):
                link = self._links.get(target)
                if link is None:
                    self._count("dropped_no_link")
                    counters = self._peer_counters.get(target)
                    if counters is not None:
                        counters.drops += 1
                    return 0
                return self._enqueue(link, data)
            case Broadcast(data, _):
                return sum(self._enqueue(link, data) for link in list(self._links.values()))
            case Publish(cells, data, _):
                self._published_cell = cells[0]
                targets = dict(self._wildcard)
                for cell in cells:
                    subs = self._cell_subs.get(cell)
                    if subs:
                        targets.update(subs)
                sent = 0
                for peer in targets:
                    link = self._links.get(peer)
                    if link is not None:
                        sent += self._enqueue(link, data)
                return sent
            case Subscribe(cells):
                self._own_subscription = cells
                self._subscribed = True
                frame = encode_subscribe(cells)
                for link in self._links.values():
                    self._enqueue(link, frame)
                return 0

    def _enqueue(self, link: _Link, data: bytes) -> int:
        try:
            link.queue.put_nowait(data)
        except asyncio.QueueFull:
            link.counters.drops += 1
            self._count("dropped_queue_full")
            return 0
        return 1

    # ------------------------------------------------------------------ dialing

    async def _supervise(self, tg: asyncio.TaskGroup) -> None:
        loop = asyncio.get_running_loop()
        next_gossip = loop.time() + self.options.gossip_interval
        while not self._closing:
            self._changed.clear()
            now = loop.time()
            wait = next_gossip - now
            for key in sorted(self._known):
                known = self._known[key]
                if not self._wants_dial(key, known, now):
                    continue
                if known.next_dial <= now:
                    known.dialing = True
                    tg.create_task(self._dial(key, known.address))
                else:
                    wait = min(wait, known.next_dial - now)
            if now >= next_gossip:
                next_gossip = now + self.options.gossip_interval
                self._gossip_all()
                wait = min(wait, self.options.gossip_interval)
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(max(wait, 0.001)):
                    await self._changed.wait()

    def _wants_dial(self, key: str, known: _Known, now: float) -> bool:
        if known.dialing or known.gone or key in self._links:
            return False
        if known.seed:
            return True
        if now - known.last_seen > self.options.forget_after:
            del self._known[key]
            return False
        return self.node_id < key

    def _backoff(self, attempts: int) -> float:
        ceiling = min(self.options.backoff_max, self.options.backoff_initial * 2.0**attempts)
        return ceiling * self._rng.uniform(0.5, 1.0)

    async def _dial(self, key: str, address: str) -> None:
        ws: ClientConnection | None = None
        link: _Link | None = None
        try:
            async with asyncio.timeout(self.options.handshake_timeout):
                ws = await connect(
                    f"ws://{address}",
                    compression=None,
                    max_size=self.options.max_frame,
                    max_queue=64,
                    proxy=None,
                    open_timeout=None,
                    close_timeout=self.options.close_timeout,
                    user_agent_header=None,
                    logger=logging.getLogger("objectplaces.mesh.websockets"),
                )
                link = await self._dial_handshake(ws, address)
        except _Refused as exc:
            log.warning("node %s: link to %s refused: %s", self.node_id, address, exc.reason)
            self._count("refused_dialing")
            if ws is not None:
                with contextlib.suppress(Exception):
                    await ws.close(exc.code, _short(exc.reason))
        except ConnectionClosed as exc:
            rcvd = exc.rcvd
            reason = f"{rcvd.code} {rcvd.reason}" if rcvd is not None else "connection lost"
            log.warning("node %s: %s refused our link: %s", self.node_id, address, reason)
            self._count("refused_by_peer")
        except (OSError, TimeoutError, InvalidHandshake, InvalidURI, DecodeError) as exc:
            log.debug("node %s: cannot reach %s: %r", self.node_id, address, exc)
            self._count("dial_failures")
            if ws is not None:
                with contextlib.suppress(Exception):
                    await ws.close()
        finally:
            self._dial_done(key, link)
        if link is not None:
            await self._run_link(link)

    def _dial_done(self, key: str, link: _Link | None) -> None:
        known = self._known.get(key)
        if known is None:
            return
        known.dialing = False
        if link is not None:
            if key.startswith("@"):
                # The seed has a name now; keep dialing it by name, as a seed.
                del self._known[key]
                known = self._learn(link.peer, link.address, link.incarnation, seed=True)
            known.attempts = 0
        else:
            known.next_dial = self._now() + self._backoff(known.attempts)
            known.attempts += 1
        self._changed.set()

    def _now(self) -> float:
        assert self._loop is not None
        return self._loop.time()

    def _learn(self, peer: str, address: str, incarnation: int, *, seed: bool = False) -> _Known:
        """Record where ``peer`` listens; a newer incarnation replaces an older one."""
        known = self._known.get(peer)
        now = self._now()
        if known is None:
            known = self._known[peer] = _Known(address, incarnation, seed=seed)
        elif incarnation > known.incarnation:
            known.address, known.incarnation = address, incarnation
            known.gone = False
            known.attempts = 0
            known.next_dial = now
        known.seed = known.seed or seed
        known.last_seen = now
        return known

    # ------------------------------------------------------------------ handshakes

    async def _dial_handshake(self, ws: ClientConnection, address: str) -> _Link:
        nonce = os.urandom(NONCE_SIZE)
        await ws.send(
            encode_hello(
                challenge=False,
                node=self.node_id,
                address=self.address,
                incarnation=self.incarnation,
                nonce=nonce,
            )
        )
        challenge = self._handshake_frame(await ws.recv())
        if not isinstance(challenge, Hello) or not challenge.challenge:
            raise _Refused(CloseCode.PROTOCOL_ERROR, "expected a challenge")
        if challenge.node == self.node_id:
            raise _Refused(CloseCode.POLICY_VIOLATION, f"{address} is this node itself")
        macs = self._macs(self.node_id, challenge.node, nonce, challenge.nonce)
        await ws.send(encode_auth(macs[0]))
        welcome = self._handshake_frame(await ws.recv())
        if not isinstance(welcome, Auth) or not welcome.welcome:
            raise _Refused(CloseCode.PROTOCOL_ERROR, "expected a welcome")
        if not hmac.compare_digest(welcome.mac, macs[1]):
            self._count("refused_auth")
            raise _Refused(CloseCode.POLICY_VIOLATION, "authentication failed")
        return self._new_link(
            challenge.node, challenge.address, challenge.incarnation, ws, self.node_id
        )

    async def _accept(self, ws: ServerConnection) -> None:
        """Serve one inbound connection: authenticate it, then run the link."""
        if self._closing or len(self._all_links) >= self.options.max_links:
            await ws.close(CloseCode.TRY_AGAIN_LATER, "too many links")
            return
        try:
            async with asyncio.timeout(self.options.handshake_timeout):
                link = await self._accept_handshake(ws)
        except _Refused as exc:
            log.warning(
                "node %s: refused a link from %s: %s", self.node_id, ws.remote_address, exc.reason
            )
            await ws.close(exc.code, _short(exc.reason))
            return
        except TimeoutError:
            self._count("refused_timeout")
            log.warning("node %s: refused %s: handshake timed out", self.node_id, ws.remote_address)
            await ws.close(CloseCode.POLICY_VIOLATION, "handshake timed out")
            return
        except ConnectionClosed:
            return
        await self._run_link(link)

    async def _accept_handshake(self, ws: ServerConnection) -> _Link:
        hello = self._handshake_frame(await ws.recv())
        if not isinstance(hello, Hello) or hello.challenge:
            raise _Refused(CloseCode.PROTOCOL_ERROR, "expected a hello")
        if hello.node == self.node_id:
            raise _Refused(CloseCode.POLICY_VIOLATION, f"node id {hello.node!r} is this node's")
        nonce = os.urandom(NONCE_SIZE)
        await ws.send(
            encode_hello(
                challenge=True,
                node=self.node_id,
                address=self.address,
                incarnation=self.incarnation,
                nonce=nonce,
            )
        )
        auth = self._handshake_frame(await ws.recv())
        macs = self._macs(hello.node, self.node_id, hello.nonce, nonce)
        if not isinstance(auth, Auth) or auth.welcome or not hmac.compare_digest(auth.mac, macs[0]):
            self._count("refused_auth")
            raise _Refused(CloseCode.POLICY_VIOLATION, f"authentication failed for {hello.node!r}")
        await ws.send(encode_auth(macs[1], welcome=True))
        return self._new_link(hello.node, hello.address, hello.incarnation, ws, hello.node)

    def _handshake_frame(self, data: str | bytes) -> Any:
        if not isinstance(data, bytes):
            self._count("refused_malformed")
            raise _Refused(CloseCode.UNSUPPORTED_DATA, "text frames are not accepted")
        try:
            return decode_transport(data, max_size=self.options.max_frame)
        except VersionMismatch as exc:
            self._count("refused_version")
            raise _Refused(CloseCode.POLICY_VIOLATION, str(exc)) from exc
        except DecodeError as exc:
            self._count("refused_malformed")
            raise _Refused(CloseCode.PROTOCOL_ERROR, f"malformed handshake: {exc}") from exc

    def _macs(
        self, dialer: str, listener: str, nonce_d: bytes, nonce_l: bytes
    ) -> tuple[bytes, bytes]:
        return handshake_macs(self._secret, dialer, listener, nonce_d, nonce_l)

    def _new_link(
        self, peer: str, address: str, incarnation: int, ws: Connection, dialer: str
    ) -> _Link:
        now = self._now()
        counters = self._peer_counters.setdefault(peer, _Counters())
        counters.address = address
        return _Link(
            peer,
            address,
            incarnation,
            ws,
            dialer,
            asyncio.Queue(self.options.queue_size),
            TokenBucket(self.options.flood_rate, self.options.flood_burst, now),
            counters,
            established=now,
        )

    # ------------------------------------------------------------------ links

    def _prefer(self, new: _Link, old: _Link) -> bool:
        """Which of two links to one peer stays (both ends reach the same answer)."""
        if new.incarnation != old.incarnation:
            return new.incarnation > old.incarnation
        if new.dialer != old.dialer:
            return new.dialer == min(self.node_id, new.peer)
        return True

    def _link_up(self, link: _Link) -> bool:
        peer = link.peer
        current = self._links.get(peer)
        if current is not None:
            if not self._prefer(link, current):
                return False
            self._retire(current, "superseded by a newer link")
        self._links[peer] = link
        known = self._learn(peer, link.address, link.incarnation)
        known.gone = False
        known.attempts = 0
        if current is None and link.counters.links:
            link.counters.reconnects += 1
        link.counters.links += 1
        previous = self._linked_incarnation.get(peer)
        self._linked_incarnation[peer] = link.incarnation
        runner = self._runner
        assert runner is not None
        if previous is not None and previous != link.incarnation:
            # The peer restarted: its earlier run is gone, with its sessions and roles.
            runner.peer_restarted(peer)
        self._drop_subscription(peer)
        if self._subscribed:
            self._enqueue(link, encode_subscribe(self._own_subscription))
        self._enqueue(link, encode_gossip(self._gossip_entries()))
        news = encode_gossip([PeerAddress(peer, link.address, link.incarnation)])
        for other, other_link in self._links.items():
            if other != peer:
                self._enqueue(other_link, news)
        self._changed.set()
        self._signal_links()
        log.info("node %s: linked with %s at %s", self.node_id, peer, link.address)
        return True

    def _retire(self, link: _Link, reason: str) -> None:
        link.retired = True
        link.close_reason = reason
        if self._tg is not None:
            self._tg.create_task(self._close_ws(link.ws, CloseCode.NORMAL, reason))

    async def _close_ws(self, ws: Connection, code: int, reason: str) -> None:
        with contextlib.suppress(Exception):
            await ws.close(code, _short(reason))

    def _link_down(self, link: _Link, reason: str) -> None:
        self._all_links.discard(link)
        self._signal_links()
        if self._links.get(link.peer) is not link:
            return
        del self._links[link.peer]
        self._drop_subscription(link.peer)
        link.counters.last_close = reason
        known = self._known.get(link.peer)
        if known is not None:
            known.last_seen = self._now()
            known.next_dial = self._now() + self._backoff(0)
            known.gone = reason.startswith(f"{CloseCode.GOING_AWAY} {_LEAVING}")
        self._changed.set()
        log.info("node %s: link with %s closed: %s", self.node_id, link.peer, reason)

    async def _run_link(self, link: _Link) -> None:
        self._all_links.add(link)
        if self._closing or not self._link_up(link):
            self._all_links.discard(link)
            await self._close_ws(link.ws, CloseCode.NORMAL, "duplicate link")
            return
        reason = "closed"
        try:
            async with asyncio.TaskGroup() as tg:
                writer = tg.create_task(self._write(link))
                try:
                    reason = await self._read(link)
                finally:
                    writer.cancel()
        finally:
            self._link_down(link, link.close_reason or reason)

    async def _write(self, link: _Link) -> None:
        queue, ws, counters = link.queue, link.ws, link.counters
        budget = min(_BATCH_BYTES, self.options.max_frame // 2)
        try:
            while True:
                first = await queue.get()
                frames: list[bytes] = []
                size = 0
                item = first
                # Whatever queued up while we waited travels as one message: a send per
                # frame costs far more than the frame itself.
                while item is not None:
                    frames.append(item)
                    size += len(item)
                    if size >= budget or len(frames) >= _BATCH_FRAMES or queue.empty():
                        break
                    item = queue.get_nowait()
                if frames:
                    data = frames[0] if len(frames) == 1 else encode_batch(frames)
                    await ws.send(data)
                    counters.messages_out += len(frames)
                    counters.bytes_out += len(data)
                if item is None:
                    await ws.close(CloseCode.GOING_AWAY, _LEAVING)
                    return
        except ConnectionClosed:
            return

    async def _read(self, link: _Link) -> str:
        """Take frames from one link until it closes; returns why it closed."""
        ws = link.ws
        try:
            async for data in ws:
                refusal = self._on_frame(link, data)
                if refusal is not None:
                    code, reason = refusal
                    self._count("links_closed_bad_input")
                    log.warning(
                        "node %s: closing link with %s: %s", self.node_id, link.peer, reason
                    )
                    link.close_reason = f"{code} {reason}"
                    await ws.close(code, _short(reason))
                    return link.close_reason
        except ConnectionClosed:
            pass
        rcvd = ws.protocol.close_rcvd
        if rcvd is not None:
            return f"{rcvd.code} {rcvd.reason}".strip()
        return "connection lost"

    def _on_frame(self, link: _Link, data: str | bytes) -> tuple[int, str] | None:
        """Handle one WebSocket message; returns (close code, reason) when the link must close."""
        if not isinstance(data, bytes):
            link.counters.messages_in += 1
            return CloseCode.UNSUPPORTED_DATA, "text frames are not accepted"
        link.counters.bytes_in += len(data)
        if len(data) > self.options.max_frame:
            link.counters.messages_in += 1
            return CloseCode.MESSAGE_TOO_BIG, (
                f"frame of {len(data)} bytes over {self.options.max_frame}"
            )
        try:
            batched = codec.frame_type(data) == BATCH
            frames = decode_transport(data).frames if batched else (data,)  # type: ignore[union-attr]
        except DecodeError as exc:
            link.counters.messages_in += 1
            return CloseCode.PROTOCOL_ERROR, f"malformed frame: {exc}"
        for frame in frames:
            refusal = self._on_one_frame(link, frame, nested=batched)
            if refusal is not None:
                return refusal
        return None

    def _on_one_frame(self, link: _Link, data: bytes, *, nested: bool) -> tuple[int, str] | None:
        """Handle one frame (on its own or out of a batch)."""
        counters = link.counters
        counters.messages_in += 1
        size = len(data)
        if not link.bucket.take(self._now()):
            return CloseCode.POLICY_VIOLATION, (
                f"flood: over {self.options.flood_rate:g} frames/s "
                f"(burst {self.options.flood_burst:g})"
            )
        if size > self.options.max_frame:
            return CloseCode.MESSAGE_TOO_BIG, f"frame of {size} bytes over {self.options.max_frame}"
        runner = self._runner
        assert runner is not None
        try:
            if codec.frame_type(data) < codec.FIRST_TRANSPORT_TYPE:
                runner.deliver(link.peer, codec.decode(data, max_size=self.options.max_frame), size)
                return None
            frame = decode_transport(data, max_size=self.options.max_frame)
        except DecodeError as exc:
            return CloseCode.PROTOCOL_ERROR, f"malformed frame: {exc}"
        match frame:
            case Gossip(peers):
                self._on_gossip(peers)
            case SubscribeCells(cells):
                self._on_subscribe(link.peer, cells)
            case Batch() if nested:
                return CloseCode.PROTOCOL_ERROR, "a batch inside a batch"
            case _:
                return CloseCode.PROTOCOL_ERROR, "handshake frame on an open link"
        return None

    # ------------------------------------------------------------------ gossip, subscriptions

    def _gossip_entries(self) -> list[PeerAddress]:
        entries = [PeerAddress(self.node_id, self.address, self.incarnation)]
        for peer, link in sorted(self._links.items()):
            entries.append(PeerAddress(peer, link.address, link.incarnation))
        return entries

    def _gossip_all(self) -> None:
        if self._links:
            frame = encode_gossip(self._gossip_entries())
            for link in self._links.values():
                self._enqueue(link, frame)

    def _on_gossip(self, peers: tuple[PeerAddress, ...]) -> None:
        for entry in peers:
            if entry.node != self.node_id:
                known = self._known.get(entry.node)
                if known is None or entry.incarnation >= known.incarnation:
                    self._learn(entry.node, entry.address, entry.incarnation)
        self._changed.set()

    def _on_subscribe(self, peer: str, cells: frozenset[Cell] | None) -> None:
        runner = self._runner
        assert runner is not None
        known = peer in self._peer_subs
        old = self._drop_subscription(peer)
        self._peer_subs[peer] = cells
        if cells is None:
            self._wildcard[peer] = None
            if not known or old is not None:
                runner.peer_joined(peer)
            return
        for cell in sorted(cells):
            self._cell_subs.setdefault(cell, {})[peer] = None
        added = cells - old if known and old is not None else cells
        if self._published_cell is not None and self._published_cell in added:
            runner.send_properties_to(peer)

    def _drop_subscription(self, peer: str) -> frozenset[Cell] | None:
        """Forget ``peer``'s subscription; returns it (None: it had everything or none)."""
        old = self._peer_subs.pop(peer, None)
        self._wildcard.pop(peer, None)
        if old is not None:
            for cell in old:
                subs = self._cell_subs.get(cell)
                if subs is not None:
                    subs.pop(peer, None)
                    if not subs:
                        del self._cell_subs[cell]
        return old
