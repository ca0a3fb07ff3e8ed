"""The in-memory network of the simulation: seeded delay, jitter, loss, duplication,
reordering and partitions, in virtual time, with real wire bytes counted.

It also plays the part a content router plays on a real deployment: it keeps the cell
subscriptions nodes declare (in a ``CellRouter``, the one the mesh uses too) and
delivers each ``Publish`` to the subscribers of its cells. When a node subscribes to a
cell, the network asks the nodes that last published there to send the newcomer their
properties, so its view fills within one delay instead of one republication interval.

Each node is attached with its ``RawNodeDriver``; time comes from a ``Scheduler``. A
node that attaches under an id seen before is a new run of it: every other node's
driver hears ``peer_restarted``. Every frame carries the run of its sender and of its
target: frames of a run that crashed, or that a new run replaced, are lost in flight,
like frames to a run that is gone. Handling one frame may raise; the network then drops
that frame, counts it (``dropped["failed"]``) and carries on, as every transport does.
"""

from __future__ import annotations

import logging
import random
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any

from objectplaces.core import codec
from objectplaces.core.errors import DecodeError, LocalProtocolError
from objectplaces.core.events import Broadcast, Output, Publish, Send, Subscribe
from objectplaces.core.messages import Message
from objectplaces.transport.base import RawNodeDriver, Scheduler
from objectplaces.transport.netstats import NetworkStats, NodeTraffic
from objectplaces.transport.routing import Cell, CellRouter

__all__ = ["LinkParams", "MemoryNetwork"]

log = logging.getLogger("objectplaces")


@dataclass(frozen=True, slots=True)
class LinkParams:
    """How one directed link behaves; delays in seconds, the rest probabilities."""

    delay: float = 0.005
    jitter: float = 0.0
    loss: float = 0.0
    duplicate: float = 0.0
    reorder: float = 0.0

    def __post_init__(self) -> None:
        for name in ("delay", "jitter"):
            value = getattr(self, name)
            if not value >= 0:
                raise LocalProtocolError(f"{name} must be >= 0 seconds, got {value!r}")
        for name in ("loss", "duplicate", "reorder"):
            value = getattr(self, name)
            if not 0 <= value <= 1:
                raise LocalProtocolError(f"{name} must be a probability in [0, 1], got {value!r}")


class MemoryNetwork:
    """Routes frames between attached nodes, in the scheduler's time.

    Args:
        loop: the clock and timer queue every delivery is scheduled on.
        rng: draws every random choice (jitter, loss, duplication, reordering).
        defaults: how every link behaves unless ``set_link`` says otherwise.
        jitter_per_frame: over links that only delay and jitter (the defaults, not
            changed by ``set_link``), draw a frame's jitter once for all its receivers,
            so that it reaches them all at one instant, as a frame on a shared medium
            does, in one event; otherwise each receiver's arrival is drawn on its own.
    """

    def __init__(
        self,
        loop: Scheduler,
        rng: random.Random,
        defaults: LinkParams,
        *,
        jitter_per_frame: bool = False,
    ) -> None:
        self.loop = loop
        self.rng = rng
        self.defaults = defaults
        self.jitter_per_frame = jitter_per_frame
        self._links: dict[tuple[str, str], LinkParams] = {}
        # node -> (its run, its driver, the number of attaches up to and with its own)
        self._nodes: dict[str, tuple[int, RawNodeDriver, int]] = {}
        self._incarnations: dict[str, int] = {}
        self._attaches = 0  # a frame sent after attach n reaches only runs attached by then
        # node -> its latest run whose frames still in flight are lost (crashed or replaced)
        self._voided: dict[str, int] = {}
        self._component: dict[str, int] | None = None
        self._router = CellRouter()
        self._traffic: dict[str, NodeTraffic] = {}
        self._dropped: dict[str, int] = {"loss": 0, "partition": 0, "dead": 0, "failed": 0}
        self._delivered = 0
        self._messages = 0
        self._bytes = 0
        self._by_kind: dict[str, list[int]] = {}

    # -- membership -----------------------------------------------------------------

    def attach(self, node: str, driver: RawNodeDriver) -> None:
        """Connect ``node``, driven by ``driver``.

        A node attached under an id seen before is a new run of it: every other live
        node's driver hears ``peer_restarted`` at once.

        Raises:
            LocalProtocolError: ``node`` is attached already.
        """
        if node in self._nodes:
            raise LocalProtocolError(f"node {node!r} is already on the network")
        previous = self._incarnations.get(node, 0)
        self._incarnations[node] = previous + 1
        if previous:
            self._voided[node] = previous  # the old run's frames must not reach anyone now
        self._attaches += 1
        self._nodes[node] = (previous + 1, driver, self._attaches)
        self._traffic.setdefault(node, NodeTraffic())
        if previous:
            for other, (_, other_driver, _) in list(self._nodes.items()):
                if other != node:
                    self._handle(other_driver.peer_restarted, node, target=other)

    def detach(self, node: str, *, graceful: bool = False) -> None:
        """Disconnect ``node`` at once: frames in flight to it are lost and, unless it
        leaves ``graceful`` (its goodbyes must still arrive), those from it too.

        Raises:
            LocalProtocolError: ``node`` is not attached.
        """
        entry = self._nodes.pop(node, None)
        if entry is None:
            raise LocalProtocolError(f"unknown node {node!r}")
        if not graceful:
            self._voided[node] = entry[0]
        self._router.forget(node)

    def __contains__(self, node: object) -> bool:
        return node in self._nodes

    @property
    def nodes(self) -> list[str]:
        """Attached nodes, in attachment order."""
        return list(self._nodes)

    # -- link behaviour ---------------------------------------------------------------

    def set_link(self, source: str, target: str, **params: float) -> None:
        """Override the behaviour of the directed link ``source -> target``."""
        base = self._links.get((source, target), self.defaults)
        try:
            self._links[(source, target)] = replace(base, **params)
        except TypeError as exc:
            raise LocalProtocolError(f"unknown link parameter in {sorted(params)}") from exc

    def partition(self, groups: Iterable[Iterable[str]]) -> None:
        """Split the network: nodes in different groups cannot reach each other.

        Nodes named in no group form one more group together.
        """
        component: dict[str, int] = {}
        for number, group in enumerate(groups, start=1):
            for node in group:
                if node in component:
                    raise LocalProtocolError(f"node {node!r} is in two partition groups")
                component[node] = number
        self._component = component

    def heal(self) -> None:
        """End every partition."""
        self._component = None

    def _separated(self, a: str, b: str) -> bool:
        component = self._component
        return component is not None and component.get(a, 0) != component.get(b, 0)

    # -- transmission -----------------------------------------------------------------

    def transmit(self, source: str, output: Output) -> int:
        """Carry one output of ``source``'s machine; return how many frames went out."""
        match output:
            case Send(target, data, kind):
                return self._send(source, (target,), data, kind)
            case Broadcast(data, kind):
                return self._send(source, [n for n in self._nodes if n != source], data, kind)
            case Publish(cells, data, kind, home, snapshot):
                if snapshot is None:
                    targets = self._router.publish(source, cells, home)
                    return self._send(source, targets, data, kind)
                heard, fresh = self._router.publish_split(source, cells, home)
                sent = self._send(source, heard, data, kind)
                return sent + self._send(source, fresh, snapshot, kind)
            case Subscribe(cells):
                self._subscribe(source, cells)
                return 0

    def _send(self, source: str, targets: Iterable[str], data: bytes, kind: str) -> int:
        message = _decoded(data)
        size = len(data)
        tally = self._traffic[source].sent.setdefault(kind, [0, 0])  # once per frame sent
        by_kind = self._by_kind.setdefault(kind, [0, 0])
        rng = self.rng
        loop = self.loop
        now = loop.now
        links = self._links
        defaults = self.defaults
        run, mark = self._incarnations[source], self._attaches
        # Frames over plain default links all arrive together: one event carries them all.
        plain = not (defaults.loss or defaults.duplicate or defaults.reorder) and (
            self.jitter_per_frame or not defaults.jitter
        )
        together: list[str] = []
        # Arrivals one by one (links with jitter, loss ...): scheduled together at the end,
        # in the order drawn, so the event queue sees the same calls in the same order.
        arrivals: list[tuple[float, tuple[Any, ...]]] = []
        count = 0
        if plain and not links and self._component is None:
            together = list(targets)  # every link is a default one: nothing to check
            count, targets = len(together), ()
        for target in targets:
            count += 1
            if self._component is not None and self._separated(source, target):
                self._dropped["partition"] += 1
                continue
            link = links.get((source, target), defaults) if links else defaults
            if plain and link is defaults:
                together.append(target)
                continue
            if link.loss and rng.random() < link.loss:
                self._dropped["loss"] += 1
                continue
            copies = 2 if link.duplicate and rng.random() < link.duplicate else 1
            for _ in range(copies):
                delay = link.delay
                if link.jitter:
                    delay += link.jitter * (2.0 * rng.random() - 1.0)
                    if delay < 0.0:
                        delay = 0.0
                if link.reorder and rng.random() < link.reorder:
                    delay += rng.random() * 4.0 * (link.delay + link.jitter)
                arrivals.append((now + delay, (source, run, mark, (target,), message, size, kind)))
        if arrivals:
            self._schedule(self._arrive, arrivals)
        if together:
            delay = defaults.delay
            if defaults.jitter:  # jitter_per_frame: one draw for every receiver
                delay = max(0.0, delay + defaults.jitter * (2.0 * rng.random() - 1.0))
            arrive = self._arrive
            loop.call_at(now + delay, arrive, source, run, mark, together, message, size, kind)
        tally[0] += count
        tally[1] += count * size
        by_kind[0] += count
        by_kind[1] += count * size
        self._messages += count
        self._bytes += count * size
        return count

    def _schedule(
        self, fn: Callable[..., None], calls: list[tuple[float, tuple[Any, ...]]]
    ) -> None:
        """``fn(*args)`` at each ``(when, args)``, in this order: in one call when the
        scheduler takes a batch (the simulation's event loop does), else one by one."""
        call_each = getattr(self.loop, "call_each", None)
        if call_each is not None:
            call_each(fn, calls)
        else:
            for when, args in calls:
                self.loop.call_at(when, fn, *args)

    def _arrive(
        self,
        source: str,
        run: int | None,
        mark: int,
        targets: Iterable[str],
        message: Message | bytes,
        size: int,
        kind: str,
    ) -> None:
        """Hand one frame to each of ``targets`` in order: to the runs they had when it
        was sent (``mark``: the attaches then), so a target that attached again since
        (a new run) or is gone loses it."""
        # ``run``: the sender's run when it sent the frame (None: injected, never lost).
        nodes, voided, traffic, dropped = self._nodes, self._voided, self._traffic, self._dropped
        void = bool(voided) and run is not None and run <= voided.get(source, 0)
        for target in targets:
            entry = nodes.get(target)
            if entry is None or entry[2] > mark or void:
                dropped["dead"] += 1
                continue
            received = traffic[target].received
            tally = received.get(kind)
            if tally is None:
                tally = received[kind] = [0, 0]
            tally[0] += 1
            tally[1] += size
            self._delivered += 1
            try:
                if isinstance(message, bytes):
                    entry[1].deliver_raw(source, message)
                else:
                    entry[1].deliver(source, message, size)
            except Exception:
                # A transport outlives any one frame: the node keeps running.
                dropped["failed"] += 1
                log.exception("node %s: handling a %s frame from %s failed", target, kind, source)

    def _handle(self, call: Callable[[str], None], peer: str, *, target: str) -> None:
        """Tell ``target``'s driver about ``peer``; a failure there stays there."""
        try:
            call(peer)
        except Exception:
            self._dropped["failed"] += 1
            log.exception("node %s: handling news of %s failed", target, peer)

    def inject(self, source: str, target: str, data: bytes) -> None:
        """Deliver raw ``data`` to ``target`` as if ``source`` had sent it.

        The frame takes the ``source -> target`` link's delay (and jitter) and then the
        same arrival path as every other frame; it is never lost, duplicated or held by
        a partition, so a test knows it arrived. ``source`` need not be a node of the
        network. Counted under the kind "injected".

        Raises:
            LocalProtocolError: ``target`` is not a live node, or ``data`` is not bytes.
        """
        if target not in self._nodes:
            raise LocalProtocolError(f"unknown node {target!r}")
        if not isinstance(data, bytes | bytearray | memoryview):
            raise LocalProtocolError(f"injected data must be bytes, got {data!r:.80}")
        data = bytes(data)
        kind = "injected"
        size = len(data)
        link = self._links.get((source, target), self.defaults)
        delay = link.delay
        if link.jitter:
            delay = max(0.0, delay + link.jitter * (2.0 * self.rng.random() - 1.0))
        sent = self._traffic.setdefault(source, NodeTraffic()).sent.setdefault(kind, [0, 0])
        by_kind = self._by_kind.setdefault(kind, [0, 0])
        for tally in (sent, by_kind):
            tally[0] += 1
            tally[1] += size
        self._messages += 1
        self._bytes += size
        args = (source, None, self._attaches, (target,), _decoded(data), size, kind)
        self.loop.call_at(self.loop.now + delay, self._arrive, *args)

    # -- cell subscriptions -------------------------------------------------------------

    def _subscribe(self, node: str, cells: frozenset[Cell] | None) -> None:
        subscribed = self._router.subscribe(node, cells)
        publishers: Iterable[str] = subscribed.publishers
        if subscribed.became_full:
            publishers = [n for n in self._nodes if n != node]
        now, links, defaults = self.loop.now, self._links, self.defaults
        syncs = [
            (
                now + links.get((node, publisher), defaults).delay,
                (publisher, self._incarnations[publisher], node),
            )
            for publisher in publishers
        ]
        self._schedule(self._sync, syncs)

    def _sync(self, publisher: str, incarnation: int, subscriber: str) -> None:
        entry = self._nodes.get(publisher)
        if entry is not None and entry[0] == incarnation and subscriber in self._nodes:
            self._handle(entry[1].send_properties_to, subscriber, target=publisher)

    # -- statistics -------------------------------------------------------------------

    def stats(self) -> NetworkStats:
        """A snapshot of the traffic so far."""
        return NetworkStats(
            messages=self._messages,
            bytes=self._bytes,
            by_kind={k: (v[0], v[1]) for k, v in sorted(self._by_kind.items())},
            per_node={
                n: NodeTraffic(
                    {k: list(v) for k, v in t.sent.items()},
                    {k: list(v) for k, v in t.received.items()},
                )
                for n, t in self._traffic.items()
            },
            dropped=dict(self._dropped),
            delivered=self._delivered,
        )


def _decoded(data: bytes) -> Message | bytes:
    """The message in ``data``, decoded once for every recipient; the bytes if it fails."""
    try:
        return codec.decode(data)
    except DecodeError:
        return data
