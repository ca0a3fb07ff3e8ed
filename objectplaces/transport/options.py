"""The WebSocket mesh's limits and timings, and the per-peer statistics it reports."""

from __future__ import annotations

from dataclasses import dataclass

from objectplaces.core import codec
from objectplaces.core.errors import LocalProtocolError

__all__ = ["MIN_FRAME", "MeshOptions", "PeerStats"]

MIN_FRAME = 64
"""The smallest ``max_frame`` a mesh takes, bytes: room for a handshake and a beat."""


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
        forget_after: a peer without a link this long is forgotten: no longer dialed,
            and its entry, incarnation and counters are dropped, whether it left, was
            lost or was only heard of through gossip. Seeds are kept and always dialed.
            Keep it longer than the nodes' failure timeout, so the machine has let go
            of a peer before the transport forgets which run of it it knew.
        gossip_interval: how often every peer is told our whole peer list.
        max_links: inbound and outbound links at most (more are refused).
        max_peers: peers the directory remembers at most; when full, the peer without
            a link that was seen longest ago makes room, and news of more peers is
            dropped while every remembered one is linked or a seed.
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
    max_peers: int = 4096
    close_timeout: float = 1.0

    def __post_init__(self) -> None:
        for name in (
            "flood_rate",
            "flood_burst",
            "handshake_timeout",
            "backoff_initial",
            "forget_after",
            "gossip_interval",
        ):
            if not getattr(self, name) > 0:
                raise LocalProtocolError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if not self.backoff_max >= self.backoff_initial:
            raise LocalProtocolError(
                f"backoff_max must be >= backoff_initial, got {self.backoff_max!r}"
            )
        if self.max_frame < MIN_FRAME or self.queue_size < 1 or self.max_links < 1:
            raise LocalProtocolError(f"limits too small in {self!r}")
        if self.max_peers < self.max_links:
            raise LocalProtocolError(
                f"max_peers must be >= max_links ({self.max_links}), got {self.max_peers!r}"
            )


@dataclass(frozen=True, slots=True)
class PeerStats:
    """Traffic with one peer the directory remembers (see ``MeshOptions.forget_after``).

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
