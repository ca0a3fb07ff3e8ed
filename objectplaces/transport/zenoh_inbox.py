"""From Zenoh's threads to the event loop: parse a sample's key, queue it, wake the loop.

Zenoh runs subscriber, liveliness and queryable callbacks on threads of its own (data
on a Python thread per subscriber, ``batched``; the rare rest directly on Zenoh's
threads, ``direct``). These callbacks do as little as they can there: read the key (a
key that is none of ours is counted and dropped), copy the payload, and append one
item to a bounded queue. The loop is woken once for everything queued meanwhile and
hands the items on in arrival order. A full queue drops new items (counted): a flood
can cost frames, never memory.

With a ``poll_interval`` data takes another way: each data subscriber keeps its samples
in a ring channel of Zenoh's (no Python thread, nobody woken), and the loop empties
every ring once per interval and hands the frames on together. A process that hears a
few hundred small frames a second (an AGV among 50) otherwise pays, per frame, a wake-up
of a Python thread and of the loop: more than the frame's own handling. A full ring
drops its oldest sample (not counted: Zenoh does not tell); frames wait up to one
interval.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import threading
from collections.abc import Callable
from typing import Any, TypeVar

import msgpack

from objectplaces.transport.routing import Cell
from objectplaces.transport.zenoh_keys import FleetKeys
from objectplaces.transport.zenoh_lib import zenoh

__all__ = ["RING_CAPACITY", "Item", "ZenohInbox", "batched", "direct"]

Item = tuple[Any, ...]
"""``("frame", source, data, cell)`` (cell: where a property update was published, else
None), ``("alive" | "gone", node, incarnation, tag)``,
``("answer", node, incarnation, tag, query)`` (a token up, answered to liveliness query
number ``query``) or ``("query", asker, cells)`` (cells None: the asker hears everything)."""

_MAX_CELLS = 4096
RING_CAPACITY = 4096
"""Samples a polled data subscriber keeps between two polls (then the oldest go)."""

T = TypeVar("T")


class ZenohInbox:
    """A bounded queue of what Zenoh delivered, drained on the event loop.

    Args:
        loop: the loop that drains it.
        on_items: called on the loop with every item queued since the last call.
        counters: where drops are counted (written on the loop only).
        max_frame: payloads larger than this are dropped unread.
        capacity: items queued at most.
        poll_interval: seconds between two polls of the data subscribers' rings (None:
            data comes by callback, each sample handed on as soon as the loop can).
    """

    def __init__(
        self,
        loop: asyncio.AbstractEventLoop,
        on_items: Callable[[list[Item]], None],
        counters: dict[str, int],
        *,
        max_frame: int,
        capacity: int = 100_000,
        poll_interval: float | None = None,
    ) -> None:
        self._loop = loop
        self._on_items = on_items
        self._counters = counters
        self._max_frame = max_frame
        self._capacity = capacity
        self._queue: collections.deque[Item] = collections.deque()
        self._scheduled = False
        self._closed = False
        self._lock = threading.Lock()
        self._drops: dict[str, int] = {}
        self._poll_interval = poll_interval
        self._polled: list[_Polled] = []
        self._poll_timer: asyncio.TimerHandle | None = None

    def close(self) -> None:
        """Queue nothing more."""
        self._closed = True
        if self._poll_timer is not None:
            self._poll_timer.cancel()
            self._poll_timer = None

    def forget_subscribers(self) -> None:
        """Poll no subscriber any more (their session is closing; what they hold is lost)."""
        self._polled.clear()

    def declare_data(
        self, session: zenoh.Session, key_expr: str, keys: FleetKeys, *, directed: bool = False
    ) -> Any:
        """Declare a data subscriber of ``keys``' fleet on ``key_expr``, by callback or
        polled (``poll_interval``); ``undeclare()`` on what it returns ends it.

        A poll hands on the samples of ``directed`` subscribers (the inbox: snapshots
        answering our questions) after every other's: a snapshot read first made the
        updates sent before it, in the same poll, stale, and they were never seen (up
        to 20 positions in a row of a node publishing every 2 ms); read last, an older
        snapshot is the stale one.
        """
        if self._poll_interval is None:
            return session.declare_subscriber(key_expr, self.data_callback(keys))
        ring: zenoh.handlers.RingChannel[zenoh.Sample] = zenoh.handlers.RingChannel(RING_CAPACITY)
        polled = _Polled(self, session.declare_subscriber(key_expr, ring), keys)
        polled.directed = directed
        undirected = sum(not p.directed for p in self._polled)
        self._polled.insert(len(self._polled) if directed else undirected, polled)
        if self._poll_timer is None and not self._closed:
            self._poll_timer = self._loop.call_later(self._poll_interval, self._poll)
        return polled

    # ------------------------------------------------------------------ Zenoh's threads

    def data_callback(self, keys: FleetKeys) -> zenoh.handlers.Callback[zenoh.Sample]:
        """The callback of a data subscriber of ``keys``' fleet."""
        max_frame = self._max_frame

        parse, me, push = keys.parse, keys.node, self._push

        def on_sample(sample: zenoh.Sample) -> None:
            inbound = parse(str(sample.key_expr))
            if inbound is None:
                self._drop("dropped_foreign_key")
            elif inbound.source == me:
                pass  # our own put, heard back through a wildcard
            else:
                payload = sample.payload  # each read of the attribute makes a new object
                if len(payload) > max_frame:
                    self._drop("dropped_oversize")
                else:
                    push(("frame", inbound.source, payload.to_bytes(), inbound.cell))

        return batched(on_sample)

    def _poll(self) -> None:
        """Empty every polled ring (on the loop), hand the frames on, poll again later."""
        self._poll_timer = None
        if self._closed:
            return
        assert self._poll_interval is not None
        self._poll_timer = self._loop.call_later(self._poll_interval, self._poll)
        items: list[Item] = []
        counters, max_frame = self._counters, self._max_frame
        for polled in self._polled:
            try_recv, parse, me = polled.subscriber.try_recv, polled.parse, polled.me
            while (sample := try_recv()) is not None:
                inbound = parse(str(sample.key_expr))
                if inbound is None:
                    counters["dropped_foreign_key"] = counters.get("dropped_foreign_key", 0) + 1
                elif inbound.source != me:  # else our own put, heard through a wildcard
                    payload = sample.payload
                    if len(payload) > max_frame:
                        counters["dropped_oversize"] = counters.get("dropped_oversize", 0) + 1
                    else:
                        items.append(("frame", inbound.source, payload.to_bytes(), inbound.cell))
        if items:
            self._on_items(items)

    def alive_callback(self, keys: FleetKeys) -> zenoh.handlers.Callback[zenoh.Sample]:
        """The callback of the liveliness subscriber of ``keys``' fleet."""

        def on_token(sample: zenoh.Sample) -> None:
            parsed = keys.parse_alive(str(sample.key_expr))
            if parsed is None:
                self._drop("dropped_foreign_key")
                return
            kind = "alive" if sample.kind == zenoh.SampleKind.PUT else "gone"
            self._push((kind, *parsed))

        return direct(on_token)

    def alive_reply_callback(
        self, keys: FleetKeys, query: int
    ) -> zenoh.handlers.Callback[zenoh.Reply]:
        """The callback of liveliness query number ``query`` of ``keys``' fleet: each
        token up when it was answered."""

        def on_reply(reply: zenoh.Reply) -> None:
            sample = reply.ok
            if sample is None:
                return  # an error reply: nothing to learn
            parsed = keys.parse_alive(str(sample.key_expr))
            if parsed is None:
                self._drop("dropped_foreign_key")
            else:
                self._push(("answer", *parsed, query))

        return direct(on_reply)

    def query_callback(self) -> zenoh.handlers.Callback[zenoh.Query]:
        """The callback of a node's queryable: who asks, and which cells it hears."""

        def on_query(query: zenoh.Query) -> None:
            payload = query.payload
            asked = None if payload is None else _parse_query(payload.to_bytes())
            if asked is None:
                self._drop("dropped_bad_query")
            else:
                self._push(("query", *asked))

        return direct(on_query)

    def _drop(self, name: str) -> None:
        with self._lock:
            self._drops[name] = self._drops.get(name, 0) + 1
        self._wake()

    def _push(self, item: Item) -> None:
        if self._closed:
            return
        if len(self._queue) >= self._capacity:
            self._drop("dropped_inbox_full")
            return
        self._queue.append(item)  # before the flag is read: the drain cannot miss it
        self._wake()

    def _wake(self) -> None:
        if self._scheduled or self._closed:
            return
        self._scheduled = True
        with contextlib.suppress(RuntimeError):  # the loop is closed: nobody listens
            self._loop.call_soon_threadsafe(self._drain)

    # ------------------------------------------------------------------ the loop

    def _drain(self) -> None:
        self._scheduled = False
        with self._lock:
            drops, self._drops = self._drops, {}
        for name, count in drops.items():
            self._counters[name] = self._counters.get(name, 0) + count
        queue = self._queue
        items = [queue.popleft() for _ in range(len(queue))]
        if items and not self._closed:
            self._on_items(items)


class _Polled:
    """A data subscriber whose samples wait in a ring until the inbox polls it."""

    __slots__ = ("directed", "inbox", "me", "parse", "subscriber")

    def __init__(self, inbox: ZenohInbox, subscriber: Any, keys: FleetKeys) -> None:
        self.directed = False
        self.inbox = inbox
        self.subscriber = subscriber
        self.parse = keys.parse
        self.me = keys.node

    def undeclare(self) -> None:
        """Poll it no more, and end the subscription (what its ring holds is dropped)."""
        with contextlib.suppress(ValueError):
            self.inbox._polled.remove(self)
        self.subscriber.undeclare()


def batched(fn: Callable[[T], None]) -> zenoh.handlers.Callback[T]:
    """``fn`` run on a Python thread of Zenoh's that takes the items from a channel.

    For data, which comes in floods: that thread runs Python all along, where a
    callback on Zenoh's own thread enters the interpreter afresh for every item. One
    node receiving a blast spent 25 µs of CPU per update this way against 42 (with
    the memory of parsed keys in both; bench/transports.py measures the difference
    at 20 nodes). The thread ends with its subscriber.
    """
    return zenoh.handlers.Callback(fn, indirect=True)


def direct(fn: Callable[[T], None]) -> zenoh.handlers.Callback[T]:
    """``fn`` run on the Zenoh thread that received the item. Zenoh's default runs each
    callback on a Python thread of its own: one more hop per sample, and threads that
    keep the interpreter from exiting while a session is open."""
    return zenoh.handlers.Callback(fn, indirect=False)


def _parse_query(data: bytes) -> tuple[str, frozenset[Cell] | None] | None:
    """``[asker, cells or None]`` from a query's payload; None if it is not that."""
    try:
        asker, cells = msgpack.unpackb(data, use_list=True)
        if not isinstance(asker, str) or not asker:
            return None
        if cells is None:
            return asker, None
        if not isinstance(cells, list) or len(cells) > _MAX_CELLS:
            return None
        parsed = frozenset((int(c[0]), int(c[1])) for c in cells if _is_cell(c))
        return (asker, parsed) if len(parsed) == len(cells) else None
    except (ValueError, TypeError, msgpack.UnpackException):
        return None


def _is_cell(value: object) -> bool:
    return (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) for v in value)
    )
