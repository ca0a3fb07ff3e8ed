"""What one authenticated link may send, checked frame by frame (sans-I/O).

A WebSocket message on an open link is one frame, or a batch of frames queued together
by the sender (``mesh_frames.BATCH``). ``LinkPolicy.read`` turns one message into what
the node should act on, in order: middleware messages to deliver, gossip, subscriptions.
It refuses, with a WebSocket close code and a reason naming the offending value:

- a text message (the mesh speaks binary only);
- a message or a frame over ``max_frame`` bytes;
- a frame that does not decode, of an unknown type, or a handshake frame on an open link;
- a batch inside a batch;
- more frames than the flood limit (a token bucket of ``flood_rate`` frames per second,
  ``flood_burst`` at once) allows.

Frames before a refused one in the same batch still count: each is handled as if it had
come alone, and the link closes after them. Time is passed in (``now``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

from objectplaces.core import codec
from objectplaces.core.errors import DecodeError
from objectplaces.core.messages import Message
from objectplaces.transport.directory import PeerCounters
from objectplaces.transport.mesh_frames import (
    BATCH,
    Batch,
    Gossip,
    SubscribeCells,
    decode_transport,
)
from objectplaces.transport.options import MeshOptions

__all__ = ["CloseCode", "Delivered", "Inbound", "LinkPolicy", "Refusal", "TokenBucket"]

FIRST_TRANSPORT: Final = codec.FIRST_TRANSPORT_TYPE


class CloseCode:
    """WebSocket close codes the mesh uses (RFC 6455 section 7.4.1)."""

    NORMAL: Final = 1000
    GOING_AWAY: Final = 1001
    PROTOCOL_ERROR: Final = 1002
    UNSUPPORTED_DATA: Final = 1003
    POLICY_VIOLATION: Final = 1008
    MESSAGE_TOO_BIG: Final = 1009
    INTERNAL_ERROR: Final = 1011
    TRY_AGAIN_LATER: Final = 1013


@dataclass(frozen=True, slots=True)
class Refusal:
    """Why a link must close: the close code and a reason for the peer and the log."""

    code: int
    reason: str


@dataclass(frozen=True, slots=True)
class Delivered:
    """A middleware message for the node machine, and its frame's size in bytes."""

    message: Message
    size: int


Inbound = Delivered | Gossip | SubscribeCells
"""What a link hands the node: a message, the peer's gossip, or its subscription."""


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


class LinkPolicy:
    """Polices what one peer sends on one link, and counts it.

    Args:
        options: the limits (``max_frame``, ``flood_rate``, ``flood_burst``).
        counters: the peer's counters; ``messages_in`` and ``bytes_in`` grow here.
        now: the time the link came up.
    """

    __slots__ = ("_bucket", "_counters", "_max_frame", "_options")

    def __init__(self, options: MeshOptions, counters: PeerCounters, now: float) -> None:
        self._options = options
        self._max_frame = options.max_frame
        self._counters = counters
        self._bucket = TokenBucket(options.flood_rate, options.flood_burst, now)

    def read(self, data: str | bytes, now: float) -> tuple[list[Inbound], Refusal | None]:
        """Check one WebSocket message.

        Returns:
            What to act on, in order, and the refusal that closes the link (None: the
            link stays open).
        """
        counters = self._counters
        if not isinstance(data, bytes):
            counters.messages_in += 1
            return [], Refusal(CloseCode.UNSUPPORTED_DATA, "text frames are not accepted")
        counters.bytes_in += len(data)
        if len(data) > self._max_frame:
            counters.messages_in += 1
            return [], self._too_big(len(data))
        try:
            batched = codec.frame_type(data) == BATCH
            batch = decode_transport(data, max_size=self._max_frame) if batched else None
        except DecodeError as exc:
            counters.messages_in += 1
            return [], Refusal(CloseCode.PROTOCOL_ERROR, f"malformed frame: {exc}")
        frames = batch.frames if isinstance(batch, Batch) else (data,)
        items: list[Inbound] = []
        seen = 0
        # The hot path of a busy link: every frame it carries comes through this loop.
        take, max_frame, first_transport = self._bucket.take, self._max_frame, FIRST_TRANSPORT
        decode, frame_type = codec.decode, codec.frame_type
        try:
            for frame in frames:
                seen += 1
                if not take(now):
                    return items, self._flood()
                size = len(frame)
                if size > max_frame:
                    return items, self._too_big(size)
                try:
                    if frame_type(frame) < first_transport:
                        items.append(Delivered(decode(frame, max_size=max_frame), size))
                        continue
                    other = decode_transport(frame, max_size=max_frame)
                except DecodeError as exc:
                    return items, Refusal(CloseCode.PROTOCOL_ERROR, f"malformed frame: {exc}")
                if isinstance(other, Gossip | SubscribeCells):
                    items.append(other)
                elif isinstance(other, Batch) and batched:
                    return items, Refusal(CloseCode.PROTOCOL_ERROR, "a batch inside a batch")
                else:
                    return items, Refusal(
                        CloseCode.PROTOCOL_ERROR, "handshake frame on an open link"
                    )
        finally:
            counters.messages_in += seen  # frames after a refused one never count
        return items, None

    def _flood(self) -> Refusal:
        options = self._options
        return Refusal(
            CloseCode.POLICY_VIOLATION,
            f"flood: over {options.flood_rate:g} frames/s (burst {options.flood_burst:g})",
        )

    def _too_big(self, size: int) -> Refusal:
        return Refusal(CloseCode.MESSAGE_TOO_BIG, f"frame of {size} bytes over {self._max_frame}")
