"""The WebSocket mesh: every node linked to every other, over authenticated WebSockets.

Links are mutual TLS (``wss://``) with a certified identity, a peer's id its
certificate's; a revoked certificate's links close within ``REVOCATION_CHECK`` s.

This module is the asyncio shell; it moves bytes and keeps the sockets. The decisions
live in sans-I/O parts, each tested alone:

- ``handshake.HandshakeMachine``: versioned hello, HMAC challenge/response;
- ``directory.PeerDirectory``: known peers and their runs, gossip, whom to dial and
  when (backoff), which of two duplicate links stays, forgetting gone peers;
- ``routing.CellRouter``: the peers' cell subscriptions, who hears a ``Publish``;
- ``policing.LinkPolicy``: what an open link may send (sizes, flood limit, frame types).

Outputs of the node machine go to the links that carry them (``fanout.Fanout``);
frames queued for a peer while its writer was busy travel as one batch.

A node outlives whatever its peers send: a link that breaks the rules, or whose frame
makes handling raise, is closed with a reason and counted; the node and its other links
carry on. Should the mesh itself stop (``run`` raises), it stops listening and drops
every link, so peers notice at once.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import random
from collections.abc import Callable, Iterable

from objectplaces.core.errors import DecodeError, LocalProtocolError
from objectplaces.core.events import Output
from objectplaces.security.links import LinkSecurity
from objectplaces.transport.base import NodeDriver
from objectplaces.transport.connector import Connector
from objectplaces.transport.directory import Dial, LinkInfo, PeerDirectory
from objectplaces.transport.fanout import Fanout
from objectplaces.transport.handshake import Established
from objectplaces.transport.link import LEAVING, Connection, MeshLink, close_quietly
from objectplaces.transport.mesh_frames import (
    Gossip,
    PeerAddress,
    SubscribeCells,
    encode_gossip,
    parse_address,
)
from objectplaces.transport.options import MeshOptions, PeerStats
from objectplaces.transport.policing import CloseCode, Delivered, Inbound, LinkPolicy
from objectplaces.transport.routing import CellRouter

__all__ = ["REVOCATION_CHECK", "WebSocketMesh"]

log = logging.getLogger("objectplaces.mesh")

REVOCATION_CHECK = 1.0
"""Seconds between two looks at the revocation list (a stat; read only when changed)."""


class WebSocketMesh:
    """One node's links to its peers.

    Args:
        node_id: this node's id.
        security: mutual TLS with the node's identity, or plain links on loopback
            (``objectplaces.security.links.link_security`` decides).
        listen: ``host:port`` to listen on (port 0 picks a free one).
        seeds: ``host:port`` of nodes to join through.
        options: limits and timings.
        incarnation: distinguishes this run of the node from earlier ones (larger is newer).
    """

    def __init__(
        self,
        node_id: str,
        *,
        security: LinkSecurity,
        listen: str = "127.0.0.1:0",
        seeds: Iterable[str] = (),
        options: MeshOptions | None = None,
        incarnation: int,
        tag: str = "",
    ) -> None:
        try:
            host, port = parse_address(listen)
            seed_list = [f"{h}:{p}" for h, p in map(parse_address, seeds)]
        except DecodeError as exc:
            raise LocalProtocolError(str(exc)) from exc
        self.node_id = node_id
        self.options = options or MeshOptions()
        self.incarnation = incarnation
        self.counters: dict[str, int] = {}
        self._security = security
        self._connector = Connector(
            node_id,
            security=security,
            host=host,
            port=port,
            incarnation=incarnation,
            options=self.options,
            counters=self.counters,
            on_link=self._run_link,
            accepting=lambda: not self._closing and len(self._all_links) < self.options.max_links,
            tag=tag,
        )
        self._driver: NodeDriver | None = None
        self._opened = False
        self._tg: asyncio.TaskGroup | None = None
        self._links: dict[str, MeshLink] = {}
        self._all_links: set[MeshLink] = set()
        self._directory = PeerDirectory(
            node_id, seeds=seed_list, options=self.options, rng=random.Random()
        )
        self._router = CellRouter()
        self._fanout = Fanout(
            node_id,
            links=self._links,
            router=self._router,
            directory=self._directory,
            counters=self.counters,
        )
        self._enqueue = self._fanout.enqueue
        self._changed = asyncio.Event()
        self._links_event = asyncio.Event()
        self._closing = False

    # ------------------------------------------------------------------ lifecycle

    def attach(self, driver: NodeDriver) -> None:
        """Connect whoever drives the node machine this mesh carries."""
        self._driver = driver

    @property
    def address(self) -> str:
        """``host:port`` this node listens on (the real port once opened)."""
        return self._connector.address

    async def open(self) -> None:
        """Start listening.

        Raises:
            OSError: the address cannot be bound.
        """
        await self._connector.open()
        self._opened = True

    async def run(self) -> None:
        """Dial, redial and gossip until closed; dialed links run inside this task group.

        However it ends, the node then stops listening and drops every link.
        """
        assert self._opened, "open() first"
        try:
            async with asyncio.TaskGroup() as tg:
                self._tg = tg
                await self._supervise(tg)
        finally:
            self._tg = None
            self.abort()

    def abort(self) -> None:
        """Stop at once: listen no more and drop every link without a goodbye."""
        self._closing = True
        self._connector.stop_listening()
        self._connector.abort_all()
        self._changed.set()

    async def close(self) -> None:
        """Flush what is queued, close every link, stop listening; then drop what is open."""
        self._closing = True
        for link in list(self._all_links):
            link.leave()
        timeout = self.options.close_timeout
        if self._all_links:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(timeout):
                    while self._all_links:
                        await self.links_changed()
        self._connector.stop_listening()
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout):
                await self._connector.wait_closed()
        self._connector.abort_all()
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

    def refusals(self) -> dict[str, str]:
        """Why peers refused our links lately, by the address dialed."""
        return dict(self._connector.refusals)

    def peer_stats(self) -> dict[str, PeerStats]:
        """Traffic counters of every remembered peer that has been linked, by id."""
        return self._directory.stats()

    @property
    def directory(self) -> PeerDirectory:
        """The peer directory (read it; the mesh alone changes it)."""
        return self._directory

    def _count(self, name: str) -> None:
        self.counters[name] = self.counters.get(name, 0) + 1

    def _now(self) -> float:
        return asyncio.get_running_loop().time()

    # ------------------------------------------------------------------ outputs

    def transmit(self, output: Output) -> int:
        """Carry one output of the machine (``Fanout.transmit``)."""
        return self._fanout.transmit(output)

    # ------------------------------------------------------------------ dialing

    async def _supervise(self, tg: asyncio.TaskGroup) -> None:
        next_revocation_check = self._now()
        while not self._closing:
            self._changed.clear()
            now = self._now()
            if self._security.tls and now >= next_revocation_check:
                next_revocation_check = now + REVOCATION_CHECK
                self._close_revoked()
            plan = self._directory.tick(now)
            for dial in plan.dials:
                tg.create_task(self._dial(dial))
            if plan.gossip and self._links:
                frame = encode_gossip(self._directory.gossip(self._own_entry()))
                for link in self._links.values():
                    self._enqueue(link, frame)
            wake = plan.next_tick
            if self._security.tls:
                wake = min(wake, next_revocation_check)
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(max(wake - now, 0.001)):
                    await self._changed.wait()

    def _close_revoked(self) -> None:
        """Close the links of peers whose certificate the revocation list now names."""
        identity = self._security.identity
        if identity is None or not identity.refresh_revocations():
            return
        for link in list(self._all_links):
            certificate = link.certificate
            if certificate is not None and identity.is_revoked(certificate):
                self._count("links_closed_revoked")
                link.close_reason = f"{CloseCode.POLICY_VIOLATION} certificate revoked"
                log.warning(
                    "node %s: closing link with %s: certificate revoked", self.node_id, link.peer
                )
                if self._tg is not None:
                    self._tg.create_task(
                        close_quietly(link.ws, CloseCode.POLICY_VIOLATION, "certificate revoked")
                    )

    def _own_entry(self) -> PeerAddress:
        return PeerAddress(self.node_id, self.address, self.incarnation)

    async def _dial(self, dial: Dial) -> None:
        linked: tuple[Established, Connection] | None = None
        try:
            linked = await self._connector.dial(dial.address)
        except Exception:
            # A fault while dialing costs this dial, never the mesh.
            log.exception("node %s: dialing %s failed", self.node_id, dial.address)
            self._count("dial_failures")
        finally:
            info = None if linked is None else _info(linked[0])
            self._directory.dial_finished(dial.key, info, dial.address, self._now())
            self._changed.set()
        if linked is not None:
            await self._run_link(*linked)

    # ------------------------------------------------------------------ links

    def _link_up(self, est: Established, ws: Connection) -> MeshLink | None:
        """Make ``ws`` the link to its peer, unless a link that stays exists already."""
        peer = est.peer
        current = self._links.get(peer)
        if self._closing or (
            current is not None and not self._directory.keep_new(_info(est), current.info)
        ):
            return None
        if current is not None:
            current.close_reason = "superseded by a newer link"
            if self._tg is not None:
                self._tg.create_task(
                    close_quietly(current.ws, CloseCode.NORMAL, current.close_reason)
                )
        now = self._now()
        counters, restarted = self._directory.link_up(
            peer, est.address, est.incarnation, now, replacing=current is not None
        )
        options = self.options
        link = MeshLink(
            est,
            ws,
            policy=LinkPolicy(options, counters, now),
            counters=counters,
            queue_size=options.queue_size,
            max_frame=options.max_frame,
            certificate=self._connector.certificate_of(ws),
        )
        self._links[peer] = link
        self._all_links.add(link)
        if restarted:
            # The peer restarted: its earlier run is gone, with its sessions and roles.
            self._tell(self._driver_or_fail().peer_restarted, peer)
        self._router.unsubscribe(peer)
        self._fanout.greet(link)
        self._enqueue(link, encode_gossip(self._directory.gossip(self._own_entry())))
        news = encode_gossip([PeerAddress(peer, est.address, est.incarnation)])
        for other, other_link in self._links.items():
            if other != peer:
                self._enqueue(other_link, news)
        self._changed.set()
        self._signal_links()
        log.info("node %s: linked with %s at %s", self.node_id, peer, est.address)
        return link

    def _link_down(self, link: MeshLink, reason: str) -> None:
        self._all_links.discard(link)
        self._signal_links()
        peer = link.peer
        if self._links.get(peer) is not link:
            return
        del self._links[peer]
        self._router.unsubscribe(peer)
        left = reason == f"{CloseCode.GOING_AWAY} {LEAVING}"
        self._directory.link_down(peer, reason, self._now(), left=left)
        self._changed.set()
        log.info("node %s: link with %s closed: %s", self.node_id, peer, reason)

    async def _run_link(self, est: Established, ws: Connection) -> None:
        link = self._link_up(est, ws)
        if link is None:
            await close_quietly(ws, CloseCode.NORMAL, "duplicate link")
            return
        reason = "closed"
        try:  # the link is registered: from here on, every way out brings it down
            reason, refusal = await link.run(
                self._driver_or_fail().deliver,
                lambda item: self._on_peer_news(est.peer, item),
                self._now,
            )
            if refusal is not None:
                failed = refusal.code == CloseCode.INTERNAL_ERROR
                self._count("links_closed_failed" if failed else "links_closed_bad_input")
                log.warning("node %s: closed link with %s: %s", self.node_id, est.peer, reason)
        except Exception:
            # A fault in this link's own handling: it costs this link, never the node.
            log.exception("node %s: link with %s failed", self.node_id, est.peer)
            self._count("links_closed_failed")
            reason = f"{CloseCode.INTERNAL_ERROR} link failed"
            ws.transport.abort()
        finally:
            self._link_down(link, reason)

    def _driver_or_fail(self) -> NodeDriver:
        driver = self._driver
        assert driver is not None, "attach() first"
        return driver

    def _on_peer_news(self, peer: str, item: Inbound) -> None:
        driver = self._driver_or_fail()
        match item:
            case Delivered(message, size):
                driver.deliver(peer, message, size)
            case Gossip(peers):
                self._directory.learn_gossip(peers, self._now())
                self._changed.set()
            case SubscribeCells(cells):
                subscribed = self._router.subscribe(peer, cells)
                if subscribed.became_full:
                    driver.peer_joined(peer)
                elif self.node_id in subscribed.publishers:
                    driver.send_properties_to(peer)

    def _tell(self, call: Callable[[str], None], peer: str) -> None:
        """Tell the driver news of ``peer``; should that raise, the link still comes up."""
        try:
            call(peer)
        except Exception:
            log.exception("node %s: telling the node about %s failed", self.node_id, peer)
            self._count("driver_errors")


def _info(est: Established) -> LinkInfo:
    return LinkInfo(est.peer, est.incarnation, est.dialer)
