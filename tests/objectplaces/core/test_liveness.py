"""The liveness beat (docs/protocol.md §2): a silent node stays heard for a few bytes a
beat, a node that publishes sends none, a missed publication is repaired by a snapshot
on request, and a beat from anyone cannot make the view grow."""

from __future__ import annotations

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from objectplaces.core import codec
from objectplaces.core.config import NodeConfig
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.events import Broadcast, Publish, Subscribe
from objectplaces.core.messages import Beat, PropertyRequest, PropertyUpdate
from objectplaces.core.node import NodeMachine
from objectplaces.core.view import SNAPSHOT_RETRY

from .wire import Wire

BEATING = NodeConfig(property_interval=30.0, beat_interval=1.0)


def pair(config: NodeConfig = BEATING) -> tuple[Wire, NodeMachine, NodeMachine]:
    a, b = NodeMachine("a", config=config), NodeMachine("b", config=config)
    wire = Wire(a, b)
    a.update_property("position", (1.0, 2.0), 0.0)
    a.update_property("status", "idle", 0.0)
    b.update_property("position", (3.0, 4.0), 0.0)
    wire.settle()
    return wire, a, b


def test_failure_timeout_is_three_of_the_shorter_liveness_interval() -> None:
    assert BEATING.effective_failure_timeout == 3.0
    assert NodeConfig(property_interval=0.5, beat_interval=1.0).effective_failure_timeout == 1.5
    assert NodeConfig(beat_interval=2.0).effective_failure_timeout == 6.0
    assert NodeConfig(beat_interval=2.0, failure_timeout=9.0).effective_failure_timeout == 9.0
    assert NodeConfig().effective_failure_timeout is None


@pytest.mark.parametrize(
    "name", ["beat_interval", "property_interval", "failure_timeout", "probe_interval"]
)
@pytest.mark.parametrize("value", [0.0, -1.0, float("nan")])
def test_a_liveness_interval_must_be_positive(name: str, value: float) -> None:
    with pytest.raises(LocalProtocolError, match=f"{name} must be > 0"):
        NodeMachine("a", config=NodeConfig(**{name: value}))  # type: ignore[arg-type]


def test_a_silent_node_beats_instead_of_republishing_and_stays_in_the_view() -> None:
    wire, _, b = pair()
    wire.run_until(20.0)
    beats = wire.frames("a", "b", Beat)
    assert len(beats) == 20  # one a second, each a few bytes
    assert {beat.seq for beat in beats} == {1}  # a's one publication: nothing new since
    assert [u.seq for u in wire.frames("a", "b", PropertyUpdate)] == [1]  # no heartbeat
    assert b.view()["a"] == {"position": (1.0, 2.0), "status": "idle"}
    assert "departed_failed" not in b.counters
    assert not wire.frames("b", "a", PropertyRequest)  # b was never behind
    wire.run_until(31.0)
    assert [u.full for u in wire.frames("a", "b", PropertyUpdate)] == [True, True]  # the rare one


def test_a_node_that_publishes_sends_no_beat() -> None:
    wire, a, _ = pair()
    for step in range(1, 41):
        wire.run_until(step * 0.5)
        a.update_property("position", (step * 0.5, 0.0), wire.now)
    wire.settle()
    assert wire.frames("a", "b", Beat) == []
    assert len(wire.frames("b", "a", Beat)) == 20  # b stood still all along


def test_a_beat_follows_a_full_interval_after_the_latest_publication() -> None:
    wire, a, _ = pair()
    wire.run_until(0.7)
    a.update_property("status", "busy", wire.now)
    wire.run_until(1.69)
    assert wire.frames("a", "b", Beat) == []  # silent for less than a beat interval
    wire.run_until(1.7)
    assert len(wire.frames("a", "b", Beat)) == 1


def test_a_crashed_node_is_detected_within_four_thirds_of_three_beats() -> None:
    wire, _, b = pair()
    wire.run_until(5.0)
    del wire.machines["a"]  # a crashes: nothing more from it
    wire.run_until(7.99)
    assert "a" in b.view()  # three beat intervals not yet over
    wire.run_until(5.0 + 4 / 3 * 3.0)
    assert "a" not in b.view()
    assert b.counters["departed_failed"] == 1


def test_a_lost_delta_is_repaired_by_the_next_beat_not_by_a_republication() -> None:
    wire, a, b = pair()
    wire.cut.add(("a", "b"))
    a.update_property("status", "busy", 0.5)
    wire.settle()
    wire.cut.clear()
    assert b.view()["a"]["status"] == "idle"
    wire.run_until(1.6)  # a's beat at 1.5 carries the number b never saw
    assert len(wire.frames("b", "a", PropertyRequest)) == 1
    assert b.view()["a"]["status"] == "busy"
    wire.run_until(10.0)
    assert len(wire.frames("b", "a", PropertyRequest)) == 1  # repaired: no more asking


def test_a_snapshot_sent_to_one_peer_does_not_make_the_others_ask() -> None:
    wire, a, _ = pair()
    c = NodeMachine("c", config=BEATING)
    wire.machines["c"] = c
    a.send_properties_to("c", 0.1)  # a unicast snapshot: a new number b never sees
    wire.run_until(5.0)
    assert wire.frames("b", "a", PropertyRequest) == []


def test_beats_go_where_the_deltas_go() -> None:
    scoped = NodeConfig(beat_interval=1.0, interest_radius=10.0, cell_size=25.0)
    a = NodeMachine("a", config=scoped)
    a.update_property("position", (30.0, 5.0), 0.0)
    a.messages_to_send()
    a.update_property("position", (60.0, 5.0), 0.5)  # into the next cell
    moved = [o for o in a.messages_to_send() if isinstance(o, Publish)]
    assert moved[0].cells == ((2, 0), (1, 0))
    a.tick(1.5)
    [beat] = a.messages_to_send()
    assert isinstance(beat, Publish)
    assert beat.cells == ((2, 0),)
    assert beat.kind == "beat"
    assert codec.decode(beat.data) == Beat(2)
    unscoped = NodeMachine("b", config=BEATING)
    unscoped.update_property("status", "idle", 0.0)
    unscoped.messages_to_send()
    unscoped.tick(1.0)
    [beat] = unscoped.messages_to_send()
    assert isinstance(beat, Broadcast)
    assert codec.decode(beat.data) == Beat(1)


def test_a_node_without_properties_sends_no_beat() -> None:
    a = NodeMachine("a", config=BEATING)
    a.tick(10.0)
    assert [o for o in a.messages_to_send() if not isinstance(o, Subscribe)] == []


def test_beats_from_strangers_never_add_to_the_view_or_to_any_table() -> None:
    b = NodeMachine("b", config=BEATING)
    for i in range(50):
        b.receive("stranger", codec.encode(Beat(10**9 + i)), now=i * 0.1)
    sent = [o for o in b.messages_to_send() if not isinstance(o, Subscribe)]
    assert {codec.decode(o.data) for o in sent} == {PropertyRequest()}  # two bytes each
    assert b.view() == {}
    assert b.footprint()["heard"] == b.footprint()["asked"] == 0
    b.tick(60.0)
    assert "departed_failed" not in b.counters  # never known, never departed


def test_a_node_behind_asks_once_per_snapshot_retry() -> None:
    _, _, b = pair()
    for i in range(50):
        b.receive("a", codec.encode(Beat(10**9 + i)), now=1.0 + i * 0.1)
    sent = [o for o in b.messages_to_send() if not isinstance(o, Subscribe)]
    assert len([o for o in sent if codec.decode(o.data) == PropertyRequest()]) == 5
    assert SNAPSHOT_RETRY == 1.0
    assert b.footprint()["asked"] == 1


def test_malformed_beats_are_refused_and_counted() -> None:
    _, _, b = pair()
    frames = (
        [11],
        [11, -3],
        [11, "x"],
        [11, 2**60],
        [11, 1, -5000],
        [11, 1, 5.0],  # not whole milliseconds
        [11, 1, 86_400_001],  # more than a day
        [11, 1, None],
        [11, 1, 5000, 1],
    )
    for frame in frames:
        b.receive("a", msgpack.packb(frame), now=0.5)
    assert b.counters["dropped_malformed"] == len(frames)
    assert b.dropped_by_peer == {"a": len(frames)}
    assert b.view()["a"]["status"] == "idle"


_FATES = st.sampled_from(["deliver", "deliver", "drop", "duplicate", "hold"])


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.tuples(st.sampled_from("xyz"), st.integers(0, 3), _FATES), min_size=1, max_size=25)
)
def test_whatever_is_lost_repeated_or_reordered_a_beat_later_the_view_is_right(
    updates: list[tuple[str, int, str]],
) -> None:
    """No republication: numbered publications and beats alone repair every loss."""
    config = NodeConfig(beat_interval=1.0)
    a, b = NodeMachine("a", config=config), NodeMachine("b", config=config)
    wire = Wire(a, b)
    wire.settle()  # their subscriptions
    held: list[bytes] = []
    for n, (name, value, fate) in enumerate(updates):
        wire.now = now = 0.01 * (n + 1)
        a.update_property(name, value, now)
        for output in a.messages_to_send():
            assert isinstance(output, Broadcast)
            if fate == "hold":
                held.append(output.data)
            for _ in range({"deliver": 1, "duplicate": 2}.get(fate, 0)):
                b.receive("a", output.data, now)
        wire.settle()  # b's requests and a's answers
    for data in reversed(held):  # late, and in the wrong order
        b.receive("a", data, wire.now)
    wire.run_until(wire.now + 2.5)  # a beat, and a snapshot if b asks
    assert b.view()["a"] == a.properties
