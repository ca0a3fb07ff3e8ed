"""Authenticated connections for the mesh: listen, dial, and run the handshake (asyncio).

With an identity, every connection is mutual TLS (``wss://``) against the fleet CA: a
peer without a certificate of the fleet, or with a revoked one, never gets past TLS or
this module, and the handshake holds the peer to the id its certificate names. Without
one (``insecure``, loopback only) links are plain ``ws://`` proven by the secret.

The handshake's decisions are the ``HandshakeMachine``'s; this module carries its bytes,
bounds it in time, closes refused connections with the machine's code and reason, and
counts each refusal (logged once per peer and reason). What it hands on is a connection
whose peer proved who it is.
"""

from __future__ import annotations

import asyncio
import logging
import os
import weakref
from collections.abc import Awaitable, Callable

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidURI

from objectplaces.core.errors import DecodeError
from objectplaces.security.identity import PeerCertificate, peer_of
from objectplaces.security.links import MEMBER_ROLES, LinkSecurity
from objectplaces.transport.handshake import Established, HandshakeMachine, Refused
from objectplaces.transport.link import Connection, close_quietly, run_handshake
from objectplaces.transport.mesh_frames import NONCE_SIZE
from objectplaces.transport.options import MeshOptions
from objectplaces.transport.policing import CloseCode

__all__ = ["Connector"]

log = logging.getLogger("objectplaces.mesh")
_ws_log = logging.getLogger("objectplaces.mesh.websockets")
_LOGGED_ONCE = 1024
"""Refusals remembered so each is logged once: bounded, a peer may vary what it sends."""

OnLink = Callable[[Established, Connection], Awaitable[None]]


class Connector:
    """Listens and dials for one node; every connection it hands on is authenticated.

    Args:
        node_id: this node's id.
        security: mutual TLS with the node's identity, or a plain link and the secret.
        host: where to listen.
        port: the port (0 picks a free one).
        incarnation: this run of the node.
        options: ``max_frame``, ``handshake_timeout``, ``close_timeout``.
        counters: node-wide counters; refusals and failed dials are counted here.
        on_link: runs an accepted link until it closes.
        accepting: whether an inbound connection may start a handshake now.
        tag: what every member of the fleet shares (a peer with another is refused).
    """

    def __init__(
        self,
        node_id: str,
        *,
        security: LinkSecurity,
        host: str,
        port: int,
        incarnation: int,
        options: MeshOptions,
        counters: dict[str, int],
        on_link: OnLink,
        accepting: Callable[[], bool],
        tag: str = "",
    ) -> None:
        self.node_id = node_id
        self.address = f"{host}:{port}"
        self._host, self._port = host, port
        self._security = security
        identity = security.identity
        self._server_tls = identity.server_context() if identity is not None else None
        self._client_tls = identity.client_context() if identity is not None else None
        self._logged: set[tuple[str, str]] = set()
        self._tag = tag
        self.refusals: dict[str, str] = {}
        """Why peers refused our links lately, by the address dialed (bounded)."""
        self._connections: weakref.WeakSet[Connection] = weakref.WeakSet()
        """Every connection dialed or accepted, from its first byte on (``abort_all``)."""
        self._incarnation = incarnation
        self._options = options
        self._counters = counters
        self._on_link = on_link
        self._accepting = accepting
        self._server: Server | None = None

    async def open(self) -> None:
        """Start listening; ``address`` then holds the real port.

        Raises:
            OSError: the address cannot be bound.
        """
        options = self._options
        self._server = await serve(
            self._accept,
            self._host,
            self._port,
            compression=None,
            max_size=options.max_frame,
            max_queue=64,
            open_timeout=options.handshake_timeout,
            close_timeout=options.close_timeout,
            server_header=None,
            logger=_ws_log,
            ssl=self._server_tls,
            create_connection=_tracked_by(self._connections),
        )
        port = self._server.sockets[0].getsockname()[1]
        host = self._host if ":" not in self._host else f"[{self._host}]"
        self.address = f"{host}:{port}"

    def stop_listening(self) -> None:
        """Accept no more connections (those open carry on)."""
        if self._server is not None:
            self._server.close()

    async def wait_closed(self) -> None:
        """Wait until the listener has stopped (after ``stop_listening``)."""
        if self._server is not None:
            await self._server.wait_closed()

    def abort_all(self) -> None:
        """Drop every connection still open, whatever stage it is at, without a goodbye.

        A connection in its opening or mesh handshake belongs to no link yet, so a node
        that stops must drop it here: left alone, it stays open for as long as the
        process lives, past the end of the node's event loop.
        """
        for ws in list(self._connections):
            ws.transport.abort()

    def _count(self, name: str) -> None:
        self._counters[name] = self._counters.get(name, 0) + 1

    def _machine(self, dialed: str = "", certified: str | None = None) -> HandshakeMachine:
        return HandshakeMachine(
            node_id=self.node_id,
            address=self.address,
            incarnation=self._incarnation,
            secret=self._security.handshake_key,
            nonce=os.urandom(NONCE_SIZE),
            dialing=bool(dialed),
            now=asyncio.get_running_loop().time(),
            timeout=self._options.handshake_timeout,
            max_frame=self._options.max_frame,
            dialed=dialed,
            certified=certified,
            tag=self._tag,
        )

    def _refused(self, refused: Refused) -> None:
        if refused.counter:
            self._count(refused.counter)

    def _log_once(self, who: str, reason: str, message: str, *args: object) -> None:
        """Log a refusal the first time this peer is refused for this reason."""
        key = (who, reason)
        if key in self._logged:
            return
        if len(self._logged) >= _LOGGED_ONCE:
            self._logged.clear()
        self._logged.add(key)
        log.warning(message, *args)

    def certificate_of(self, ws: Connection) -> PeerCertificate | None:
        """Who the peer on ``ws`` proved to be by its certificate (None on a plain link)."""
        if self._server_tls is None:
            return None
        return peer_of(ws.transport.get_extra_info("ssl_object"))

    def _vet(self, ws: Connection) -> tuple[str | None, Refused | None]:
        """The id the peer's certificate names, or why it may not link at all."""
        identity = self._security.identity
        if identity is None:
            return None, None
        peer = self.certificate_of(ws)
        if peer is None:
            return None, Refused(
                CloseCode.POLICY_VIOLATION, "no member certificate", "refused_certificate"
            )
        if peer.fleet != identity.fleet or peer.role not in MEMBER_ROLES:
            return None, Refused(
                CloseCode.POLICY_VIOLATION,
                f"certificate of {peer.node_id!r} is for {peer.role!r} of fleet "
                f"{peer.fleet!r}, not a member of {identity.fleet!r}",
                "refused_role",
            )
        identity.refresh_revocations()
        if identity.is_revoked(peer):
            return None, Refused(
                CloseCode.POLICY_VIOLATION,
                f"certificate of {peer.node_id!r} is revoked",
                "refused_revoked",
            )
        return peer.node_id, None

    async def dial(self, address: str) -> tuple[Established, ClientConnection] | None:
        """Connect to ``address`` and authenticate; None when that failed (logged, counted)."""
        options = self._options
        ws: ClientConnection | None = None
        try:
            async with asyncio.timeout(options.handshake_timeout):
                ws = await connect(
                    f"{'wss' if self._client_tls is not None else 'ws'}://{address}",
                    compression=None,
                    max_size=options.max_frame,
                    max_queue=64,
                    proxy=None,
                    open_timeout=None,
                    close_timeout=options.close_timeout,
                    user_agent_header=None,
                    logger=_ws_log,
                    ssl=self._client_tls,
                )
                self._connections.add(ws)
                certified, refused = self._vet(ws)
                outcome = refused or await run_handshake(
                    ws, self._machine(dialed=address, certified=certified)
                )
        except ConnectionClosed as exc:
            rcvd = exc.rcvd
            reason = f"{rcvd.code} {rcvd.reason}" if rcvd is not None else "connection lost"
            self._log_once(
                address, reason, "node %s: %s refused our link: %s", self.node_id, address, reason
            )
            self._count("refused_by_peer")
            self.refusals.pop(address, None)
            self.refusals[address] = reason  # newest last
            if len(self.refusals) > _LOGGED_ONCE:
                del self.refusals[next(iter(self.refusals))]
            return None
        except (OSError, TimeoutError, InvalidHandshake, InvalidURI, DecodeError) as exc:
            log.debug("node %s: cannot reach %s: %r", self.node_id, address, exc)
            self._count("dial_failures")
            await close_quietly(ws)
            return None
        if isinstance(outcome, Refused):
            self._log_once(
                address,
                outcome.reason,
                "node %s: link to %s refused: %s",
                self.node_id,
                address,
                outcome.reason,
            )
            self._refused(outcome)
            self._count("refused_dialing")
            await close_quietly(ws, outcome.code, outcome.reason)
            return None
        return outcome, ws

    async def _accept(self, ws: ServerConnection) -> None:
        """Serve one inbound connection: authenticate it, then run the link."""
        if not self._accepting():
            await ws.close(CloseCode.TRY_AGAIN_LATER, "too many links")
            return
        certified, refused = self._vet(ws)
        machine = self._machine(certified=certified)
        outcome: Established | Refused
        if refused is not None:
            outcome = refused
        else:
            try:
                async with asyncio.timeout_at(machine.deadline):
                    outcome = await run_handshake(ws, machine)
            except TimeoutError:
                outcome = machine.expire()
            except ConnectionClosed:
                return
        if isinstance(outcome, Established):
            await self._on_link(outcome, ws)
            return
        who = certified or str(ws.remote_address[0] if ws.remote_address else "?")
        self._log_once(
            who,
            outcome.reason,
            "node %s: refused a link from %s: %s",
            self.node_id,
            ws.remote_address,
            outcome.reason,
        )
        self._refused(outcome)
        await close_quietly(ws, outcome.code, outcome.reason)


def _tracked_by(connections: weakref.WeakSet[Connection]) -> type[ServerConnection]:
    """A server connection that joins ``connections`` as soon as TLS has let it in."""

    class TrackedServerConnection(ServerConnection):
        def connection_made(self, transport: asyncio.BaseTransport) -> None:
            super().connection_made(transport)
            connections.add(self)

    return TrackedServerConnection
