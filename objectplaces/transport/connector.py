"""Authenticated connections for the mesh: listen, dial, and run the handshake (asyncio).

The handshake's decisions are the ``HandshakeMachine``'s; this module carries its bytes,
bounds it in time, closes refused connections with the machine's code and reason, and
counts each refusal. What it hands on is a connection whose peer proved the secret.
"""

from __future__ import annotations

import asyncio
import logging
import os
from collections.abc import Awaitable, Callable

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidURI

from objectplaces.core.errors import DecodeError
from objectplaces.transport.handshake import Established, HandshakeMachine, Refused
from objectplaces.transport.link import Connection, close_quietly, run_handshake
from objectplaces.transport.mesh_frames import NONCE_SIZE
from objectplaces.transport.options import MeshOptions
from objectplaces.transport.policing import CloseCode

__all__ = ["Connector"]

log = logging.getLogger("objectplaces.mesh")
_ws_log = logging.getLogger("objectplaces.mesh.websockets")

OnLink = Callable[[Established, Connection], Awaitable[None]]


class Connector:
    """Listens and dials for one node; every connection it hands on is authenticated.

    Args:
        node_id: this node's id.
        secret: the mesh's shared secret.
        host: where to listen.
        port: the port (0 picks a free one).
        incarnation: this run of the node.
        options: ``max_frame``, ``handshake_timeout``, ``close_timeout``.
        counters: node-wide counters; refusals and failed dials are counted here.
        on_link: runs an accepted link until it closes.
        accepting: whether an inbound connection may start a handshake now.
    """

    def __init__(
        self,
        node_id: str,
        *,
        secret: bytes,
        host: str,
        port: int,
        incarnation: int,
        options: MeshOptions,
        counters: dict[str, int],
        on_link: OnLink,
        accepting: Callable[[], bool],
    ) -> None:
        self.node_id = node_id
        self.address = f"{host}:{port}"
        self._host, self._port = host, port
        self._secret = secret
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

    def _count(self, name: str) -> None:
        self._counters[name] = self._counters.get(name, 0) + 1

    def _machine(self, dialed: str = "") -> HandshakeMachine:
        return HandshakeMachine(
            node_id=self.node_id,
            address=self.address,
            incarnation=self._incarnation,
            secret=self._secret,
            nonce=os.urandom(NONCE_SIZE),
            dialing=bool(dialed),
            now=asyncio.get_running_loop().time(),
            timeout=self._options.handshake_timeout,
            max_frame=self._options.max_frame,
            dialed=dialed,
        )

    def _refused(self, refused: Refused) -> None:
        if refused.counter:
            self._count(refused.counter)

    async def dial(self, address: str) -> tuple[Established, ClientConnection] | None:
        """Connect to ``address`` and authenticate; None when that failed (logged, counted)."""
        options = self._options
        ws: ClientConnection | None = None
        try:
            async with asyncio.timeout(options.handshake_timeout):
                ws = await connect(
                    f"ws://{address}",
                    compression=None,
                    max_size=options.max_frame,
                    max_queue=64,
                    proxy=None,
                    open_timeout=None,
                    close_timeout=options.close_timeout,
                    user_agent_header=None,
                    logger=_ws_log,
                )
                outcome = await run_handshake(ws, self._machine(dialed=address))
        except ConnectionClosed as exc:
            rcvd = exc.rcvd
            reason = f"{rcvd.code} {rcvd.reason}" if rcvd is not None else "connection lost"
            log.warning("node %s: %s refused our link: %s", self.node_id, address, reason)
            self._count("refused_by_peer")
            return None
        except (OSError, TimeoutError, InvalidHandshake, InvalidURI, DecodeError) as exc:
            log.debug("node %s: cannot reach %s: %r", self.node_id, address, exc)
            self._count("dial_failures")
            await close_quietly(ws)
            return None
        if isinstance(outcome, Refused):
            log.warning("node %s: link to %s refused: %s", self.node_id, address, outcome.reason)
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
        machine = self._machine()
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
        log.warning(
            "node %s: refused a link from %s: %s", self.node_id, ws.remote_address, outcome.reason
        )
        self._refused(outcome)
        await close_quietly(ws, outcome.code, outcome.reason)
