"""Traffic figures of the simulated network: per node, per kind, and what was dropped."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["NetworkStats", "NodeTraffic"]


@dataclass(slots=True)
class NodeTraffic:
    """Messages and bytes one node sent and received, by message kind."""

    sent: dict[str, list[int]] = field(default_factory=dict)
    received: dict[str, list[int]] = field(default_factory=dict)

    @property
    def sent_messages(self) -> int:
        """Messages this node put on the wire."""
        return sum(v[0] for v in self.sent.values())

    @property
    def sent_bytes(self) -> int:
        """Bytes this node put on the wire."""
        return sum(v[1] for v in self.sent.values())

    @property
    def received_messages(self) -> int:
        """Messages delivered to this node."""
        return sum(v[0] for v in self.received.values())

    @property
    def received_bytes(self) -> int:
        """Bytes delivered to this node."""
        return sum(v[1] for v in self.received.values())


@dataclass(frozen=True, slots=True)
class NetworkStats:
    """Traffic of the whole simulated network.

    Attributes:
        messages: frames put on the wire (one per recipient).
        bytes: their total size.
        by_kind: kind -> (messages, bytes).
        per_node: node -> its traffic.
        dropped: reason -> frames dropped: "loss", "partition", "dead" (the target was
            gone, or the sender crashed or restarted since it sent the frame), "failed"
            (handling the frame raised; the target lives on).
        delivered: frames that reached a live node.
    """

    messages: int
    bytes: int
    by_kind: dict[str, tuple[int, int]]
    per_node: dict[str, NodeTraffic]
    dropped: dict[str, int]
    delivered: int
