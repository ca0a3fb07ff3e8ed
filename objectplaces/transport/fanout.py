"""The mesh's outputs: each output of the node machine onto the links that carry it.

``Send`` goes to its target's link, ``Broadcast`` to every link, ``Publish`` to the peers
whose subscription covers one of its cells (``routing.CellRouter``); ``Subscribe`` is
declared to every peer (a mesh has no router) and again to each new one. A frame that
finds its peer's queue full is dropped and counted; nothing here blocks.
"""

from __future__ import annotations

from objectplaces.core.events import Broadcast, Output, Publish, Send, Subscribe
from objectplaces.transport.directory import PeerDirectory
from objectplaces.transport.link import MeshLink
from objectplaces.transport.mesh_frames import encode_subscribe
from objectplaces.transport.routing import Cell, CellRouter

__all__ = ["Fanout"]


class Fanout:
    """Carries one node's outputs to its links.

    Args:
        node_id: the node's id.
        links: the live link of each peer (the mesh keeps it; read here).
        router: the peers' cell subscriptions.
        directory: the peers' counters (a frame for a peer without a link is a drop).
        counters: node-wide counters.
    """

    __slots__ = (
        "_counters",
        "_directory",
        "_links",
        "_node_id",
        "_router",
        "subscribed",
        "subscription",
    )

    def __init__(
        self,
        node_id: str,
        *,
        links: dict[str, MeshLink],
        router: CellRouter,
        directory: PeerDirectory,
        counters: dict[str, int],
    ) -> None:
        self._node_id = node_id
        self._links = links
        self._router = router
        self._directory = directory
        self._counters = counters
        self.subscribed = False
        """Whether this node has subscribed yet."""
        self.subscription: frozenset[Cell] | None = None
        """The cells it last subscribed to (None: every cell)."""

    def transmit(self, output: Output) -> int:
        """Carry one output of the machine (never blocks; a full queue drops the frame).

        Returns:
            How many frames were queued for the wire.
        """
        links = self._links
        match output:
            case Send(target, data, _):
                link = links.get(target)
                if link is None:
                    self._count("dropped_no_link")
                    counters = self._directory.counters(target)
                    if counters is not None:
                        counters.drops += 1
                    return 0
                return self.enqueue(link, data)
            case Broadcast(data, _):
                return sum(self.enqueue(link, data) for link in list(links.values()))
            case Publish(cells, data, _, home, snapshot):
                if snapshot is None:
                    routed = [(self._router.publish(self._node_id, cells, home), data)]
                else:  # split before the router records the new home: who heard the last
                    heard, fresh = self._router.publish_split(self._node_id, cells, home)
                    routed = [(heard, data), (fresh, snapshot)]
                sent = 0
                for peers, frame in routed:
                    for peer in peers:
                        link = links.get(peer)
                        if link is not None:
                            sent += self.enqueue(link, frame)
                return sent
            case Subscribe(cells):
                self.subscribed = True
                self.subscription = cells
                frame = encode_subscribe(cells)
                for link in links.values():
                    self.enqueue(link, frame)
                return 0

    def greet(self, link: MeshLink) -> None:
        """Tell a new link our subscription, once we have made one."""
        if self.subscribed:
            self.enqueue(link, encode_subscribe(self.subscription))

    def enqueue(self, link: MeshLink, data: bytes) -> int:
        """Queue ``data`` for ``link``; 1, or 0 when its queue is full (counted)."""
        if link.enqueue(data):
            return 1
        self._count("dropped_queue_full")
        return 0

    def _count(self, name: str) -> None:
        self._counters[name] = self._counters.get(name, 0) + 1
