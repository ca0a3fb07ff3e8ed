"""Declared publishers for the keys a node puts on again and again (bounded, LRU).

A put through a declared ``zenoh.Publisher`` travels with a short numeric id in place
of its key once Zenoh has declared it to the peers, and skips parsing the key each
time. A node puts on few keys (its cell, the inboxes of the nodes it talks to), so a
small cache holds them all; the key used longest ago makes room when it is full.
"""

from __future__ import annotations

from collections import OrderedDict

from objectplaces.transport.zenoh_lib import zenoh

__all__ = ["PublisherCache"]


class PublisherCache:
    """Publishers of one session by key, at most ``capacity`` of them."""

    def __init__(self, session: zenoh.Session, capacity: int = 256) -> None:
        self._session = session
        self._capacity = capacity
        self._publishers: OrderedDict[str, zenoh.Publisher] = OrderedDict()

    def put(self, key: str, data: bytes) -> None:
        """Put ``data`` on ``key`` (declaring its publisher first if need be).

        Raises:
            zenoh.ZError: Zenoh refused the put.
        """
        publishers = self._publishers
        publisher = publishers.get(key)
        if publisher is None:
            publisher = self._session.declare_publisher(key)
            publishers[key] = publisher
            if len(publishers) > self._capacity:
                _, oldest = publishers.popitem(last=False)
                oldest.undeclare()  # type: ignore[no-untyped-call]
        else:
            publishers.move_to_end(key)
        publisher.put(data)

    def __len__(self) -> int:
        return len(self._publishers)
