"""``SimulatedNetwork``: many ObjectPlaces nodes in one process, in virtual time.

Seeded and deterministic: the same seed and the same calls give the same run, message
for message. Every frame goes through the wire codec, so ``stats()`` counts real bytes.
Its defaults are those of a node on a real network (``start_node``): properties are
republished every second and a node not heard for three seconds leaves every group, so
a protocol tested here meets crashes as it will on the mesh.
"""

from __future__ import annotations

import enum
import random
from collections.abc import Callable, Iterable, Mapping
from typing import Any, Final, Literal

from objectplaces.activator import RoleActivator
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.events import Output, TimerHandle
from objectplaces.core.messages import Message
from objectplaces.core.node import NodeConfig, NodeMachine
from objectplaces.runtime.pump import Pump
from objectplaces.runtime.sim import EventLoop
from objectplaces.transport.memory import LinkParams, MemoryNetwork
from objectplaces.transport.netstats import NetworkStats
from tuplespace import TupleSpace

__all__ = ["SimulatedNetwork"]


class _Default(enum.Enum):
    """The value of an ``add_node`` option left to the network's default."""

    UNSET = enum.auto()


_UNSET: Final = _Default.UNSET


class _SimNode:
    """One node on the simulated network: its machine, pump and facade."""

    def __init__(self, net: SimulatedNetwork, machine: NodeMachine, space: TupleSpace) -> None:
        self.net = net
        self.machine = machine
        self.timer_at: float | None = None
        self.wake_pending = False
        self.alive = True
        node_id = machine.node_id
        self.pump = Pump(machine, self._transmit, self._schedule)
        self.activator = RoleActivator(machine, clock=net._now, wake=self.wake, space=space)
        self._node_id = node_id
        self._loop = net._loop

    def _transmit(self, output: Output) -> int:
        return self.net._network.transmit(self._node_id, output)

    def _schedule(self, deadline: float | None) -> None:
        if deadline is None or not self.alive:
            return
        if self.timer_at is None or deadline < self.timer_at:
            self.timer_at = deadline
            self.net._loop.call_at(deadline, self._on_timer)

    def _on_timer(self) -> None:
        if not self.alive:
            return
        now = self.net._loop.now
        if self.timer_at is not None and self.timer_at <= now:
            self.timer_at = None
        self.machine.tick(now)
        self.pump.drain()
        if self.timer_at is None:
            # The drain may have found nothing to do; the timer must re-arm regardless.
            self._schedule(self.machine.next_deadline())

    def wake(self) -> None:
        # Inside a drain (a role acting in its callback) the drain itself picks it up.
        if not self.wake_pending and self.alive and not self.pump.draining:
            self.wake_pending = True
            self.net._loop.call_at(self.net._loop.now, self._on_wake)

    def _on_wake(self) -> None:
        self.wake_pending = False
        if self.alive:
            self.pump.drain()

    # The driver side the memory network calls (transport.base.RawNodeDriver). Whatever
    # an input does, the drain in ``finally`` sends what the machine queued before it.

    def deliver(self, source: str, message: Message, size: int) -> None:
        machine = self.machine
        try:
            machine.receive_message(source, message, self._loop.now, size=size)
        finally:
            if machine.has_work():  # most frames leave nothing to drain: no call then
                self.pump.drain()

    def deliver_raw(self, source: str, data: bytes) -> None:
        try:
            self.machine.receive(source, data, self._loop.now)
        finally:
            self.pump.drain()

    def peer_joined(self, peer: str) -> None:
        self.machine.peer_joined(peer, self.net._loop.now)
        self.wake()

    def peer_restarted(self, peer: str) -> None:
        self.machine.peer_restarted(peer, self.net._loop.now)
        self.wake()

    def send_properties_to(self, peer: str) -> None:
        try:
            self.machine.send_properties_to(peer, self.net._loop.now)
        finally:
            self.pump.drain()


def _run_unless_cancelled(handle: TimerHandle) -> None:
    if not handle.cancelled:
        handle.fn()


class SimulatedNetwork:
    """An in-memory network of ObjectPlaces nodes driven by a virtual clock.

    Args:
        seed: seeds every random choice (delay jitter, loss, duplication, reordering).
        delay: one-way delay of every link, seconds.
        jitter: delays vary uniformly within +-jitter.
        jitter_per_frame: draw a frame's jitter once for all its receivers over links
            that only delay and jitter (a shared medium: they hear it at one instant, in
            one event) instead of once per receiver (``MemoryNetwork``).
        loss: probability that a frame is lost.
        duplicate: probability that a frame arrives twice.
        reorder: probability that a frame is held back by up to 4x (delay + jitter).
        cell_size: grid cell side for scoped dissemination and the spatial index.
        property_interval: default republication interval of new nodes, 1 s as on a
            real network (``start_node``); None: never, and without ``beat_interval``
            no failure detection either (a crashed node then stays in its groups).
        beat_interval: default liveness beat interval of new nodes (None: no beats;
            ``NodeConfig`` says what a beat is).
        rest_beat_interval: default beat interval of new nodes at rest (None: no rest;
            ``NodeConfig.rest_beat_interval``).
        failure_timeout: default failure timeout of new nodes (None: 3 liveness
            intervals, 3 s with the defaults).
        retransmit_timeout: first retransmission delay of session channel frames.
        probe_interval: how often an initiator probes its idle members (None: never;
            ``NodeConfig.probe_interval``).
    """

    def __init__(
        self,
        seed: int = 0,
        *,
        delay: float = 0.005,
        jitter: float = 0.0,
        jitter_per_frame: bool = False,
        loss: float = 0.0,
        duplicate: float = 0.0,
        reorder: float = 0.0,
        cell_size: float = 25.0,
        property_interval: float | None = 1.0,
        beat_interval: float | None = None,
        rest_beat_interval: float | None = None,
        failure_timeout: float | None = None,
        retransmit_timeout: float = 0.2,
        probe_interval: float | None = NodeConfig().probe_interval,
    ) -> None:
        self.seed = seed
        self._loop = EventLoop()
        self._network = MemoryNetwork(
            self._loop,
            random.Random(seed),
            LinkParams(delay, jitter, loss, duplicate, reorder),
            jitter_per_frame=jitter_per_frame,
        )
        self._defaults = NodeConfig(
            property_interval=property_interval,
            beat_interval=beat_interval,
            rest_beat_interval=rest_beat_interval,
            failure_timeout=failure_timeout,
            cell_size=cell_size,
            retransmit_timeout=retransmit_timeout,
            probe_interval=probe_interval,
        )
        self._nodes: dict[str, _SimNode] = {}

    def _now(self) -> float:
        return self._loop.now

    @property
    def now(self) -> float:
        """The virtual time, in seconds since the network was made."""
        return self._loop.now

    @property
    def cell_size(self) -> float:
        """The side of the grid cells its nodes publish and subscribe in, metres."""
        return self._defaults.cell_size

    @property
    def loop(self) -> EventLoop:
        """The event loop (to schedule application work in virtual time)."""
        return self._loop

    def add_node(
        self,
        node_id: str,
        *,
        interest_radius: float | None = None,
        footprint_margin: float | None = None,
        property_interval: float | Literal[_Default.UNSET] | None = _UNSET,
        beat_interval: float | Literal[_Default.UNSET] | None = _UNSET,
        rest_beat_interval: float | Literal[_Default.UNSET] | None = _UNSET,
        failure_timeout: float | Literal[_Default.UNSET] | None = _UNSET,
        space: TupleSpace | None = None,
    ) -> RoleActivator:
        """Add a node (a restarted node may reuse the id of a removed one).

        Args:
            node_id: unique among live nodes.
            interest_radius: scoped dissemination radius (None: hear every node).
            footprint_margin: with an interest radius, publish to the cells within the
                node's radius plus this margin (``NodeConfig.footprint_margin``).
            property_interval: overrides the network's default.
            beat_interval: overrides the network's default.
            rest_beat_interval: overrides the network's default.
            failure_timeout: overrides the network's default.
            space: the node's tuplespace (a new one on the virtual clock by default).

        Raises:
            LocalProtocolError: the id is taken or invalid.
        """
        if node_id in self._nodes:
            raise LocalProtocolError(f"node {node_id!r} is already on the network")
        if interest_radius is not None and not interest_radius > 0:
            raise LocalProtocolError(f"interest_radius must be > 0, got {interest_radius!r}")
        defaults = self._defaults
        config = NodeConfig(
            property_interval=(
                defaults.property_interval if property_interval is _UNSET else property_interval
            ),
            beat_interval=defaults.beat_interval if beat_interval is _UNSET else beat_interval,
            rest_beat_interval=(
                defaults.rest_beat_interval if rest_beat_interval is _UNSET else rest_beat_interval
            ),
            failure_timeout=(
                defaults.failure_timeout if failure_timeout is _UNSET else failure_timeout
            ),
            interest_radius=interest_radius,
            footprint_margin=footprint_margin,
            cell_size=defaults.cell_size,
            retransmit_timeout=defaults.retransmit_timeout,
            probe_interval=defaults.probe_interval,
        )
        space = space if space is not None else TupleSpace(clock=self._now)
        machine = NodeMachine(node_id, now=self.now, config=config, space=space)
        node = _SimNode(self, machine, space)
        self._nodes[node_id] = node
        self._network.attach(node_id, node)
        node.wake()
        return node.activator

    def remove_node(self, node_id: str) -> None:
        """Crash ``node_id``: it stops at once, sends nothing more, and loses what is in flight.

        Raises:
            LocalProtocolError: no such live node.
        """
        self._stop(node_id, graceful=False)

    def leave(self, node_id: str) -> None:
        """Remove ``node_id`` gracefully: it stops its sessions and tells every peer (its
        goodbyes still arrive; a crash would lose them)."""
        node = self._nodes.get(node_id)
        if node is None:
            raise LocalProtocolError(f"unknown node {node_id!r}")
        node.machine.leave(self.now)
        node.pump.drain()
        self._stop(node_id, graceful=True)

    def _stop(self, node_id: str, *, graceful: bool) -> None:
        node = self._nodes.pop(node_id, None)
        if node is None:
            raise LocalProtocolError(f"unknown node {node_id!r}")
        node.alive = False
        self._network.detach(node_id, graceful=graceful)

    def node(self, node_id: str) -> RoleActivator:
        """The live node ``node_id``.

        Raises:
            LocalProtocolError: no such live node.
        """
        node = self._nodes.get(node_id)
        if node is None:
            raise LocalProtocolError(f"unknown node {node_id!r}")
        return node.activator

    @property
    def nodes(self) -> Mapping[str, RoleActivator]:
        """Every live node by id, in the order they were added."""
        return {node_id: node.activator for node_id, node in self._nodes.items()}

    def set_link(
        self, source: str, target: str, *, both_ways: bool = True, **params: float
    ) -> None:
        """Change ``delay``, ``jitter``, ``loss``, ``duplicate`` or ``reorder`` of one link."""
        self._network.set_link(source, target, **params)
        if both_ways:
            self._network.set_link(target, source, **params)

    def partition(self, *groups: Iterable[str]) -> None:
        """Split the network into ``groups`` (unnamed nodes form one more group)."""
        self._network.partition(groups)

    def heal(self) -> None:
        """Reconnect every partition."""
        self._network.heal()

    def run_for(self, seconds: float) -> None:
        """Advance virtual time by ``seconds``, delivering and firing everything due."""
        if not seconds >= 0:
            raise LocalProtocolError(f"seconds must be >= 0, got {seconds!r}")
        self._loop.run_until(self._loop.now + seconds)

    def run_until(self, predicate: Callable[[], bool], timeout: float) -> bool:
        """Advance until ``predicate()`` holds (checked after every event) or ``timeout`` passes.

        Returns:
            True when the predicate held.
        """
        if predicate():
            return True
        return self._loop.run_until(self._loop.now + timeout, predicate)

    def inject(self, source: str, target: str, data: bytes) -> None:
        """Deliver raw bytes to ``target`` as if ``source`` had sent them: the hostile peer.

        The bytes take the ``source -> target`` link's delay (and jitter), then the
        same receive path real frames take: decoded once, handed to the target's
        machine, malformed ones refused and counted there (``dropped_malformed``).
        Injected frames are never lost, duplicated or stopped by a partition, so the
        test knows they arrived; they count under the kind "injected" in ``stats()``.
        Should handling one raise, the network drops that frame, counts it in
        ``stats().dropped["failed"]``, logs it, and the target keeps running.

        Args:
            source: the claimed sender; any id, a node of this network or not.
            target: a live node.
            data: the frame's bytes, well-formed or not.

        Raises:
            LocalProtocolError: ``target`` is not a live node, or ``data`` is not bytes.
        """
        self._network.inject(source, target, data)

    def call_later(self, delay: float, fn: Callable[[], Any]) -> TimerHandle:
        """Run ``fn`` after ``delay`` virtual seconds (for drivers of simulated
        applications): the contract of a node's ``call_later``, on no node.

        Returns:
            A handle whose ``cancel()`` stops ``fn`` from running.

        Raises:
            LocalProtocolError: ``delay`` is negative or not a number.
        """
        if not delay >= 0:
            raise LocalProtocolError(f"delay must be >= 0 seconds, got {delay!r}")
        handle = TimerHandle(self._loop.now + delay, fn)
        self._loop.call_at(handle.deadline, _run_unless_cancelled, handle)
        return handle

    def stats(self) -> NetworkStats:
        """Messages and bytes so far, in total, per node and per message kind."""
        return self._network.stats()
