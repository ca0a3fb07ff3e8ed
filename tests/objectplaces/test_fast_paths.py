"""The simulation's fast paths give the results of the plain ones.

The property view skips the per-property loop for a heartbeat that changes nothing, the
event loop schedules the arrivals of one frame in one call, and the simulated network
collects those arrivals before scheduling them. Each must leave every result as the
plain path would: the same values, the same sequence numbers, the same order of events.
"""

from __future__ import annotations

import gc
import random
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from objectplaces.core import codec
from objectplaces.core.config import NodeConfig
from objectplaces.core.events import Broadcast
from objectplaces.core.messages import PropertyUpdate
from objectplaces.core.observers import Observers
from objectplaces.core.plumbing import Plumbing
from objectplaces.core.view import PropertyView
from objectplaces.runtime.sim import GC_ALLOCATIONS, EventLoop
from objectplaces.transport.memory import LinkParams, MemoryNetwork


def _view() -> PropertyView:
    plumbing = Plumbing.build("me", NodeConfig(cell_size=10.0))
    return PropertyView(plumbing, observers=Observers(plumbing.outbox))


_update = st.tuples(
    st.integers(0, 12),
    st.booleans(),
    st.dictionaries(st.sampled_from("xyz"), st.integers(0, 2), min_size=1),
)


@given(updates=st.lists(_update, max_size=40))
def test_view_ends_as_newest_wins_per_property_whatever_the_mix_of_snapshots(
    updates: list[tuple[int, bool, dict[str, int]]],
) -> None:
    v = _view()
    model: dict[str, tuple[int, int]] = {}
    for seq, full, values in updates:
        changed = v.apply("b", PropertyUpdate(seq, values, full), now=0.0)
        before = dict(model)
        for name, value in values.items():
            if name not in model or seq > model[name][0]:
                model[name] = (seq, value)
        assert changed == (
            {n: sv[1] for n, sv in model.items()} != {n: sv[1] for n, sv in before.items()}
        )
        assert dict(v.props_of("b") or {}) == {n: sv[1] for n, sv in model.items()}


def test_an_unchanged_heartbeat_still_moves_the_sequence_numbers() -> None:
    v = _view()
    assert v.apply("b", PropertyUpdate(1, {"x": 1, "y": 2}, True), now=0.0)
    assert not v.apply("b", PropertyUpdate(7, {"x": 1, "y": 2}, True), now=1.0)
    # A delta older than the heartbeat must not win, although it came later.
    assert not v.apply("b", PropertyUpdate(5, {"x": 9}), now=2.0)
    assert v.props_of("b") == {"x": 1, "y": 2}
    assert v.apply("b", PropertyUpdate(8, {"x": 9}), now=3.0)
    assert v.props_of("b") == {"x": 9, "y": 2}


def test_forgotten_node_starts_over_from_any_sequence_number() -> None:
    v = _view()
    v.apply("b", PropertyUpdate(9, {"x": 1}, True), now=0.0)
    v.forget("b")
    assert v.apply("b", PropertyUpdate(2, {"x": 1}, True), now=1.0)
    assert v.props_of("b") == {"x": 1}


def test_call_each_runs_in_time_order_ties_in_the_given_order_and_past_calls_now() -> None:
    loop = EventLoop(start=5.0)
    ran: list[tuple[str, float]] = []

    def note(name: str) -> None:
        ran.append((name, loop.now))

    loop.call_at(6.0, note, "single")
    loop.call_each(note, [(6.0, ("a",)), (5.5, ("b",)), (6.0, ("c",)), (1.0, ("past",))])
    assert not loop.run_until(10.0)
    assert ran == [("past", 5.0), ("b", 5.5), ("single", 6.0), ("a", 6.0), ("c", 6.0)]
    assert loop.events_run == 5
    assert loop.now == 10.0


class _PlainScheduler:
    """A scheduler with ``call_at`` alone: the network must not need more."""

    def __init__(self) -> None:
        self.loop = EventLoop()

    @property
    def now(self) -> float:
        return self.loop.now

    def call_at(self, when: float, fn: Any, *args: Any) -> None:
        self.loop.call_at(when, fn, *args)


class _Driver:
    def __init__(self, name: str, log: list[tuple[str, str, float]], clock: Any) -> None:
        self.name, self.log, self.clock = name, log, clock

    def deliver(self, source: str, message: Any, size: int) -> None:
        self.log.append((source, self.name, self.clock()))

    def deliver_raw(self, source: str, data: bytes) -> None:
        self.log.append((source, self.name, self.clock()))

    def peer_joined(self, peer: str) -> None:
        """Not used here."""

    def peer_restarted(self, peer: str) -> None:
        """Not used here."""

    def send_properties_to(self, peer: str) -> None:
        """Not used here."""


def _arrivals(with_call_each: bool) -> list[tuple[str, str, float]]:
    log: list[tuple[str, str, float]] = []
    plain = _PlainScheduler()
    loop: Any = plain.loop if with_call_each else plain
    net = MemoryNetwork(loop, random.Random(3), LinkParams(0.005, jitter=0.004, duplicate=0.3))
    for name in "abcdef":
        net.attach(name, _Driver(name, log, lambda: plain.loop.now))
    for sender in "abc":
        net.transmit(sender, Broadcast(codec.encode(PropertyUpdate(1, {"x": 1})), "property"))
    plain.loop.run_until(1.0)
    return log


def test_network_schedules_the_same_arrivals_with_or_without_call_each() -> None:
    with_each, without = _arrivals(True), _arrivals(False)
    assert len(with_each) > 15  # every sender reached all five others, some twice
    assert with_each == without


def test_a_batch_waits_as_one_heap_entry_and_keeps_its_place_among_single_calls() -> None:
    loop = EventLoop()
    ran: list[str] = []
    loop.call_each(ran.append, [(0.3, ("c",)), (0.1, ("a",)), (0.2, ("b",))])
    assert len(loop) == 1
    loop.call_at(0.15, ran.append, "single")
    loop.call_each(ran.append, [(0.2, ("b2",)), (0.05, ("first",))])
    assert loop.next_time() == 0.05
    assert loop.run_until(1.0, stop=lambda: ran[-1] == "b") is True
    assert ran == ["first", "a", "single", "b"]
    assert not loop.run_until(1.0)
    assert ran == ["first", "a", "single", "b", "b2", "c"]
    assert len(loop) == 0


def test_the_collector_is_spaced_while_events_run_and_restored_after() -> None:
    loop = EventLoop()
    before = gc.get_threshold()
    seen: list[tuple[int, ...]] = []
    loop.call_at(0.1, lambda: seen.append(gc.get_threshold()))
    loop.run_until(1.0)
    assert seen[0][0] == max(before[0], GC_ALLOCATIONS)
    assert gc.get_threshold() == before


def test_a_beat_takes_its_short_path_with_the_same_accounting() -> None:
    from objectplaces.core.messages import Beat
    from objectplaces.core.node import NodeMachine

    a = NodeMachine("a")
    a.messages_to_send()  # its subscription
    a.receive_message("a", Beat(3), 1.0, size=4)  # claims to be us: tallied, dropped
    assert a.counters == {"dropped_own": 1}
    a.receive_message("b", Beat(3), 1.0, size=4)  # not in the view: asked for a snapshot
    assert [type(o).__name__ for o in a.messages_to_send()] == ["Send"]
    a.receive_message("b", PropertyUpdate(3, {"x": 1}, full=True), 2.0, size=9)
    a.messages_to_send()
    a.receive_message("b", Beat(3), 5.0, size=5)  # the latest publication: only heard
    assert a.messages_to_send() == []
    assert a.received_by_kind["beat"] == [3, 13]
    assert a.received_by_kind["property"] == [1, 9]
    a.receive_message("b", Beat(4), 6.0, size=4)  # a publication missed: snapshot asked
    assert [type(o).__name__ for o in a.messages_to_send()] == ["Send"]


def test_a_delivered_frame_is_drained_when_it_leaves_work_and_only_then() -> None:
    from objectplaces.core.messages import Beat
    from objectplaces.sim import SimulatedNetwork

    net = SimulatedNetwork(seed=1)
    a, b = net.add_node("a"), net.add_node("b")
    a.update_node_property("x", 1)
    net.run_for(1.0)
    sent_before = net.stats().per_node["b"].sent.get("property", [0, 0])[0]
    net.inject("a", "b", codec.encode(Beat(1)))  # a's latest publication: nothing to do
    net.run_for(1.0)
    assert net.stats().per_node["b"].sent.get("property", [0, 0])[0] == sent_before
    net.inject("ghost", "b", codec.encode(Beat(4)))  # unknown: b asks it for a snapshot
    net.run_for(1.0)
    assert net.stats().per_node["b"].sent["property"][0] == sent_before + 1
    assert b.view()["a"] == {"x": 1}


def test_the_plain_outputs_and_messages_keep_a_frozen_values_equality_and_hash() -> None:
    from objectplaces.core.events import Callback, Publish, Send
    from objectplaces.core.messages import Beat, ChannelAck, ChannelData, FrameKind

    pairs = [
        (Send("a", b"x", "k"), Send("a", b"x", "k")),
        (Publish(((0, 1),), b"x", "property", 1, None), Publish(((0, 1),), b"x", "property")),
        (Callback(print, (1,), "s"), Callback(print, (1,), "s")),
        (Beat(3), Beat(3)),
        (
            ChannelData(True, 1, 1, 0, FrameKind.ROLE, 5),
            ChannelData(True, 1, 1, 0, FrameKind.ROLE, 5),
        ),
        (ChannelAck(False, 1, 1, 4), ChannelAck(False, 1, 1, 4)),
    ]
    for one, other in pairs:
        assert one == other
        assert hash(one) == hash(other)
        assert len({one, other}) == 1
    assert Beat(3) != Beat(4)
    assert Send("a", b"x", "k") != Send("b", b"x", "k")
