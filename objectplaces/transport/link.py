"""One authenticated WebSocket link of the mesh, and the byte pumps around it (asyncio).

A ``MeshLink`` owns one connection after its handshake: a bounded queue of frames for
the peer, drained by a writer that sends whatever queued up meanwhile as one batch, and
a reader that hands each message to the link's ``LinkPolicy`` and what it allows to the
node. Whatever handling one frame raises closes this link with code 1011 and a reason,
never the node. Decisions stay in the sans-I/O parts; this module only moves bytes.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from typing import Final

from websockets.asyncio.client import ClientConnection
from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed

from objectplaces.core.messages import Message
from objectplaces.security.identity import PeerCertificate
from objectplaces.transport.directory import LinkInfo, PeerCounters
from objectplaces.transport.handshake import Established, HandshakeMachine, Refused
from objectplaces.transport.mesh_frames import encode_batch
from objectplaces.transport.policing import CloseCode, Delivered, Inbound, LinkPolicy, Refusal

__all__ = [
    "LEAVING",
    "Connection",
    "Deliver",
    "MeshLink",
    "close_quietly",
    "run_handshake",
    "short_reason",
]

log = logging.getLogger("objectplaces.mesh")

Connection = ServerConnection | ClientConnection
Deliver = Callable[[str, Message, int], None]
LEAVING: Final = "leaving"
"""The close reason (with code 1001) of a node that leaves the mesh for good."""
_BATCH_BYTES: Final = 64 * 1024
_BATCH_FRAMES: Final = 512


def short_reason(reason: str) -> str:
    """Fit a close reason in the 123 bytes a close frame allows."""
    encoded = reason.encode()
    return reason if len(encoded) <= 120 else encoded[:117].decode(errors="ignore") + "..."


async def close_quietly(
    ws: Connection | None, code: int = CloseCode.NORMAL, reason: str = ""
) -> None:
    """Close ``ws`` (if any) with ``code`` and ``reason``; a dead connection is fine."""
    if ws is not None:
        with contextlib.suppress(Exception):
            await ws.close(code, short_reason(reason))


async def run_handshake(ws: Connection, machine: HandshakeMachine) -> Established | Refused:
    """Pump bytes between ``ws`` and the handshake machine until it has an outcome.

    Raises:
        ConnectionClosed: the peer went away first.
    """
    for data in machine.data_to_send():
        await ws.send(data)
    while machine.outcome is None:
        machine.receive(await ws.recv())
        for data in machine.data_to_send():
            await ws.send(data)
    return machine.outcome


class MeshLink:
    """One authenticated link to a peer.

    Args:
        est: who the handshake says the peer is.
        ws: the connection.
        policy: polices what the peer sends.
        counters: the peer's traffic counters.
        queue_size: frames queued for the peer before new ones are dropped.
        max_frame: the largest frame, bytes (a batch stays within half of it).
        certificate: who the peer proved to be by TLS (None on a plain link).
    """

    __slots__ = (
        "_budget",
        "address",
        "certificate",
        "close_reason",
        "counters",
        "info",
        "policy",
        "queue",
        "ws",
    )

    def __init__(
        self,
        est: Established,
        ws: Connection,
        *,
        policy: LinkPolicy,
        counters: PeerCounters,
        queue_size: int,
        max_frame: int,
        certificate: PeerCertificate | None = None,
    ) -> None:
        self.info = LinkInfo(est.peer, est.incarnation, est.dialer)
        self.certificate = certificate
        self.address = est.address
        self.ws = ws
        self.policy = policy
        self.counters = counters
        self.queue: asyncio.Queue[bytes | None] = asyncio.Queue(queue_size)
        self.close_reason = ""
        self._budget = min(_BATCH_BYTES, max_frame // 2)

    @property
    def peer(self) -> str:
        """The peer's id."""
        return self.info.peer

    def enqueue(self, data: bytes) -> bool:
        """Queue one frame for the peer; False (and counted) when the queue is full."""
        try:
            self.queue.put_nowait(data)
        except asyncio.QueueFull:
            self.counters.drops += 1
            return False
        return True

    def leave(self) -> None:
        """Close with "leaving" once what is queued has gone out."""
        with contextlib.suppress(asyncio.QueueFull):
            self.queue.put_nowait(None)

    async def run(
        self, deliver: Deliver, handle: Callable[[Inbound], None], now: Callable[[], float]
    ) -> tuple[str, Refusal | None]:
        """Carry frames both ways until the link closes.

        Args:
            deliver: takes each middleware message (``NodeDriver.deliver``).
            handle: takes the peer's gossip and subscriptions.
            now: the clock the flood limit runs on.

        If ``deliver`` or ``handle`` raises, the link closes (code 1011, the error named).

        Returns:
            Why the link closed, and the refusal that closed it (None: the peer or the
            network closed it, or this node left).
        """
        refusal: Refusal | None = None
        async with asyncio.TaskGroup() as tg:
            writer = tg.create_task(self._write())
            try:
                refusal = await self._read(deliver, handle, now)
            finally:
                writer.cancel()
        if self.close_reason:
            return self.close_reason, refusal
        rcvd = self.ws.protocol.close_rcvd
        if rcvd is not None:
            return f"{rcvd.code} {rcvd.reason}".strip(), refusal
        return "connection lost", refusal

    async def _write(self) -> None:
        queue, ws, counters, budget = self.queue, self.ws, self.counters, self._budget
        try:
            while True:
                item = await queue.get()
                frames: list[bytes] = []
                size = 0
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
                    await ws.close(CloseCode.GOING_AWAY, LEAVING)
                    return
        except ConnectionClosed:
            return

    async def _read(
        self, deliver: Deliver, handle: Callable[[Inbound], None], now: Callable[[], float]
    ) -> Refusal | None:
        ws = self.ws
        try:
            async for data in ws:
                refusal = self._on_message(data, deliver, handle, now())
                if refusal is not None:
                    self.close_reason = f"{refusal.code} {refusal.reason}"
                    await ws.close(refusal.code, short_reason(refusal.reason))
                    return refusal
        except ConnectionClosed:
            pass
        return None

    def _on_message(
        self,
        data: str | bytes,
        deliver: Deliver,
        handle: Callable[[Inbound], None],
        now: float,
    ) -> Refusal | None:
        items, refusal = self.policy.read(data, now)
        peer = self.peer
        item: Inbound | None = None
        try:
            for item in items:
                if type(item) is Delivered:  # the hot path: most frames are messages
                    deliver(peer, item.message, item.size)
                else:
                    handle(item)
        except Exception as exc:
            # Nothing one frame does may stop the node: close this link, say why.
            log.error("handling a frame from %s failed", peer, exc_info=True)
            what = type(item.message if isinstance(item, Delivered) else item).__name__
            return Refusal(
                CloseCode.INTERNAL_ERROR, f"failed handling {what}: {type(exc).__name__}: {exc}"
            )
        return refusal
