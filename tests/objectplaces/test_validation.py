"""Boundaries validate once: the local API refuses bad values at the call, and nothing a
peer sends can raise out of the node machine (issue 10, item 1)."""

from __future__ import annotations

import logging
import math
from typing import Any

import msgpack
import pytest

from objectplaces import LocalProtocolError, groups
from objectplaces.core import codec
from objectplaces.core.config import NodeConfig
from objectplaces.core.intake import LOG_BUDGET
from objectplaces.core.messages import ChannelAck, ChannelData, FrameKind, PropertyUpdate
from objectplaces.core.node import NodeMachine
from objectplaces.core.values import MAX_DEPTH
from objectplaces.sim import SimulatedNetwork

from .recording import RecordingInitiator, RecordingParticipant, place

UNUSABLE_POSITIONS = [["x", "y"], [math.nan, 0], [math.inf, -math.inf], [None, 1], [1e308, 0]]


def nested(depth: int) -> Any:
    value: Any = 1
    for _ in range(depth):
        value = [value]
    return value


@pytest.mark.parametrize(
    ("name", "value", "error", "reason"),
    [
        ("position", ("x", "y"), ValueError, "two finite numbers"),
        ("position", (math.nan, 0.0), ValueError, "two finite numbers"),
        ("position", (math.inf, -math.inf), ValueError, "two finite numbers"),
        ("position", (None, 1), ValueError, "two finite numbers"),
        ("position", (1.0, 2.0, 3.0), ValueError, "two finite numbers"),
        ("position", None, ValueError, "two finite numbers"),
        ("position", (True, 1), ValueError, "two finite numbers"),
        ("position", (1e308, 0.0), ValueError, "within"),  # no whole millimetres for it
        ("hull_length", 1e300, ValueError, "finite number >= 0"),
        ("hull_length", -0.5, ValueError, "finite number >= 0"),
        ("hull_length", math.inf, ValueError, "finite number >= 0"),
        ("hull_length", "2", ValueError, "finite number >= 0"),
        ("status", object(), TypeError, "not serialisable as plain data"),
        ("status", {"a": [1, {2, 3}]}, TypeError, r"\['a'\]\[1\] is \{2, 3\}"),
        ("status", {(1, 2): "tuple key"}, TypeError, "key"),
        ("status", nested(MAX_DEPTH + 1), ValueError, "nested deeper"),
        ("status", 2**64, ValueError, "out of the wire's range"),
        ("status", b"x" * 70_000, ValueError, "over the limit"),
        ("", 1, ValueError, "non-empty string"),
    ],
)
def test_the_local_api_refuses_bad_values_at_the_call_and_queues_nothing(
    name: str, value: Any, error: type[Exception], reason: str
) -> None:
    net = SimulatedNetwork(seed=1)
    a, b = net.add_node("a"), net.add_node("b")
    a.update_node_property("status", "ok")
    net.run_for(0.1)
    before = net.stats().messages
    with pytest.raises(error, match=reason) as raised:
        a.update_node_property(name, value)
    assert isinstance(raised.value, LocalProtocolError)  # what callers caught before
    net.run_for(0.1)
    assert net.stats().messages == before  # nothing was queued
    assert dict(a.properties) == {"status": "ok"}
    assert b.view()["a"] == {"status": "ok"}


def test_plain_values_within_the_bounds_are_accepted() -> None:
    net = SimulatedNetwork(seed=1)
    a, b = net.add_node("a"), net.add_node("b")
    value = {"k": [1, 2.5, None, True, b"\x00", ("t", {"deep": nested(MAX_DEPTH - 5)})]}
    a.update_node_property("status", value)
    a.update_node_property("position", [1, 2])  # a list of ints is a position too
    net.run_for(0.1)
    assert b.view()["a"]["position"] == (1.0, 2.0)
    assert b.view()["a"]["status"]["k"][0] == 1


def test_all_properties_together_must_fit_in_a_frame() -> None:
    a = NodeMachine("a", config=NodeConfig(max_frame=100_000))
    for i in range(3):
        a.update_property(f"blob{i}", b"x" * 15_000, now=0.0)
    with pytest.raises(ValueError, match="over half the frame limit"):
        a.update_property("blob3", b"x" * 15_000, now=0.0)
    a.update_property("blob0", b"", now=0.0)  # replacing a value frees its share
    a.update_property("blob3", b"x" * 15_000, now=0.0)


@pytest.mark.parametrize("position", UNUSABLE_POSITIONS)
def test_a_peers_unusable_position_never_raises_and_the_frame_is_dropped_whole(
    position: list[Any],
) -> None:
    machine = NodeMachine("a")
    machine.update_property("position", (0.0, 0.0), now=0.0)
    machine.update_property("hull_length", 1.0, now=0.0)
    machine.start_session(RecordingInitiator(), groups.circles_overlap(), "voter", now=0.0)
    frame = msgpack.packb([1, 7, {"position": position, "hull_length": 1.0, "status": "x"}])
    machine.receive("evil", frame, now=1.0)  # used to raise in the spatial index
    assert machine.view() == {}  # nothing of the frame was applied, not even "status"
    assert machine.counters["dropped_invalid_property"] == 1
    assert machine.dropped_by_peer == {"evil": 1}
    machine.receive("evil", codec.encode(PropertyUpdate(8, {"position": (0.5, 0.0)})), now=2.0)
    assert machine.view_group(groups.circles_overlap()) == frozenset({"evil"})


@pytest.mark.parametrize(
    "frame",
    [
        msgpack.packb([1, 2**60, {"status": "x"}]),  # absurd sequence number
        msgpack.packb([4, 2**62, 1, 0, 0, ["voter", "R"]]),  # absurd session
        msgpack.packb([4, 5, 1, 3, 4, {"role": "message"}]),  # unknown session, mid-stream
        msgpack.packb([4, 6, 1, 0, 3, None]),  # a DEACTIVATE out of nowhere
        msgpack.packb([5, 99, 1, 0, 1, None]),  # ACTIVATED for a session we never started
        msgpack.packb([6, 3, 1, 1_000_000]),  # ack of a channel that does not exist
        msgpack.packb([7, 3, 1, 5]),
        msgpack.packb([2, "seq", 1, 2]),
        msgpack.packb([3, "extra"]),
        b"\x00",
        b"",
    ],
)
def test_nothing_a_peer_sends_raises_or_leaves_state_behind(frame: bytes) -> None:
    machine = NodeMachine("a", config=NodeConfig(property_interval=0.5))
    machine.set_factory("voter", lambda: RecordingParticipant([]))
    machine.receive("evil", frame, now=1.0)
    assert machine.view() == {}
    assert set(machine.state_counts().values()) == {0}  # no state made up from it
    assert sum(machine.counters.values()) == 1  # whatever it was, it was counted
    for _ in range(50):  # and nothing it left behind raises later
        deadline = machine.next_deadline()
        assert deadline is not None
        machine.tick(deadline)
        machine.messages_to_send()
        machine.events_received()


@pytest.mark.parametrize("payload", ["not a list", [42], [], None, ["no-such-role", "R"]])
def test_an_activation_with_a_junk_payload_is_declined(payload: Any) -> None:
    machine = NodeMachine("a")
    machine.set_factory("voter", lambda: RecordingParticipant([]))
    machine.receive("b", msgpack.packb([4, 1, 1, 0, 0, payload]), now=1.0)
    sent = [codec.decode(o.data) for o in machine.messages_to_send() if hasattr(o, "data")]
    assert ChannelData(False, 1, 1, 0, FrameKind.DECLINED, None) in sent
    assert machine.participations() == []


def test_bad_frames_are_logged_at_most_once_per_peer_per_minute(
    caplog: pytest.LogCaptureFixture,
) -> None:
    net = SimulatedNetwork(seed=2)
    a, b = net.add_node("a"), net.add_node("b")
    bad = msgpack.packb([1, 1, {"position": [math.nan, 0.0]}])
    with caplog.at_level(logging.WARNING, logger="objectplaces"):
        for _ in range(5):
            net.inject("mallory", "a", bad)
            net.inject("eve", "a", b"garbage")
            net.run_for(10.0)  # 50 s in all: still within the first minute
        first = [r.getMessage() for r in caplog.records]
        net.run_for(10.0)
        net.inject("mallory", "a", bad)  # more than a minute after the first line
        net.run_for(1.0)
    assert len([m for m in first if "mallory" in m]) == 1
    assert len([m for m in first if "eve" in m]) == 1
    assert len([r for r in caplog.records if "mallory" in r.getMessage()]) == 2
    assert a.stats().counters["dropped_invalid_property"] == 6
    assert a.stats().counters["dropped_malformed"] == 5
    assert a.stats().dropped_by_peer == {"eve": 5, "mallory": 6}
    assert net.stats().dropped["failed"] == 0  # the machine itself never raised
    b.update_node_property("status", "still heard")
    net.run_for(0.1)
    assert a.view()["b"] == {"status": "still heard"}


def test_a_hostile_peer_does_not_stop_an_honest_group() -> None:
    net = SimulatedNetwork(seed=3)
    log: list[Any] = []
    a, b = net.add_node("a"), net.add_node("b")
    b.set_participant_factory("voter", lambda: RecordingParticipant(log))
    place(a, 0, 0)
    place(b, 1, 0)
    net.run_for(0.1)
    role = RecordingInitiator(greeting="hi")
    a.start_interaction(role, groups.circles_overlap(), "voter")
    for position in UNUSABLE_POSITIONS:
        net.inject("b", "a", msgpack.packb([1, 10**6, {"position": position}]))
    net.inject("b", "a", codec.encode(ChannelAck(True, 1, 1, 10**6)))
    net.inject("b", "a", codec.encode(ChannelData(False, 1, 1, 500, FrameKind.ROLE, "forged")))
    net.run_for(1.0)
    place(b, 1.5, 0)
    net.run_for(0.5)
    assert role.membership() == [("in", "b")]
    assert ("b", "receive", "hi") in log
    assert a.view()["b"]["position"] == (1.5, 0.0)
    assert net.stats().dropped["failed"] == 0


def test_a_peer_inventing_names_cannot_flood_the_log(caplog: pytest.LogCaptureFixture) -> None:
    net = SimulatedNetwork(seed=4)
    a = net.add_node("a")
    with caplog.at_level(logging.WARNING, logger="objectplaces"):
        for i in range(500):
            net.inject(f"name-{i}", "a", b"garbage")
        net.run_for(30.0)
        within_a_minute = len(caplog.records)
        net.run_for(40.0)
        net.inject("yet-another", "a", b"garbage")
        net.run_for(1.0)
    assert within_a_minute == LOG_BUDGET
    assert len(caplog.records) == LOG_BUDGET + 1  # a new minute, a new budget
    assert a.stats().counters["dropped_malformed"] == 501  # every one counted all the same
    assert len(a.stats().dropped_by_peer) == 501


def test_a_compact_frame_beyond_the_coordinate_range_is_refused_whole() -> None:
    machine = NodeMachine("a")
    machine.receive("b", msgpack.packb([2, 1, 2**62, 0, 1000, {"status": "x"}]), now=0.0)
    machine.receive("b", msgpack.packb([10, 2, 0, 0, 2**62]), now=0.0)
    assert machine.view() == {}
    assert machine.counters["dropped_invalid_property"] == 2
