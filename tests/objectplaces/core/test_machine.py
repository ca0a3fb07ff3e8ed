"""NodeMachine alone: bytes in, bytes out, every input with ``now``; no simulator."""

from __future__ import annotations

from typing import Any, ClassVar

import pytest

from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef, groups
from objectplaces.core import codec
from objectplaces.core.channel import retransmission_span
from objectplaces.core.config import NodeConfig
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.events import Broadcast, Send, Subscribe
from objectplaces.core.messages import (
    ChannelAck,
    ChannelData,
    FrameKind,
    Leave,
    PropertyRequest,
    PropertyUpdate,
)
from objectplaces.core.node import NodeMachine

from .wire import Wire

Log = list[tuple[Any, ...]]


class Recorder(Initiator):
    def __init__(self) -> None:
        self.log: Log = []

    def in_group(self, participant: ParticipantRef) -> None:
        self.log.append(("in", participant.node_id, self.now()))

    def out_group(self, participant: ParticipantRef) -> None:
        self.log.append(("out", participant.node_id, self.now()))

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        self.log.append(("recv", participant.node_id, message))


class Echo(Participant):
    log: ClassVar[Log] = []
    instances: ClassVar[list[Echo]] = []

    def __init__(self) -> None:
        Echo.instances.append(self)

    def in_group_of(self, initiator: InitiatorRef) -> None:
        Echo.log.append(("in_group_of", self.node_id, initiator.node_id))

    def out_group_of(self, initiator: InitiatorRef) -> None:
        Echo.log.append(("out_group_of", self.node_id, initiator.node_id))

    def receive(self, message: Any) -> None:
        self.send(["echo", message])


@pytest.fixture(autouse=True)
def _fresh_echo_log() -> None:
    Echo.log = []
    Echo.instances = []


def pair(**config: Any) -> tuple[NodeMachine, NodeMachine, Wire]:
    a = NodeMachine("a", config=NodeConfig(**config))
    b = NodeMachine("b", config=NodeConfig(**config))
    b.set_factory("echo", Echo)
    wire = Wire(a, b)
    a.update_property("position", (0.0, 0.0), 0.0)
    b.update_property("position", (1.0, 0.0), 0.0)
    wire.settle()
    return a, b, wire


def test_a_property_update_is_one_compact_frame_with_a_fresh_sequence_number() -> None:
    a = NodeMachine("a")
    assert a.messages_to_send() == [Subscribe(None)]  # full dissemination: hear everyone
    a.update_property("position", (1.0, 2.0), 0.5)
    a.update_property("hull_length", 2.5, 0.5)
    [frame] = a.messages_to_send()
    assert isinstance(frame, Broadcast)
    assert codec.decode(frame.data) == PropertyUpdate(
        1, {"position": (1.0, 2.0), "hull_length": 2.5}, full=True
    )
    assert len(frame.data) <= 16  # the paper's budget for a position update
    assert a.messages_to_send() == []


def test_a_frame_in_moves_the_view_and_queues_observer_callbacks() -> None:
    a = NodeMachine("a")
    seen: Log = []
    a.observers.add_property(lambda *args: seen.append(args))
    a.receive("b", codec.encode(PropertyUpdate(3, {"status": "idle"}, full=True)), now=1.0)
    assert seen == []  # observers are application code: they run when the driver drains
    for event in a.events_received():
        event.fn(*event.args)
    assert seen == [("b", "status", "idle")]
    assert a.view() == {"b": {"status": "idle"}}
    a.receive("b", codec.encode(PropertyUpdate(2, {"status": "old"})), now=1.1)
    assert a.view()["b"]["status"] == "idle"  # an older sequence number loses


def test_the_view_and_own_properties_are_read_only() -> None:
    a = NodeMachine("a")
    a.update_property("status", "idle", 0.0)
    a.receive("b", codec.encode(PropertyUpdate(1, {"status": "busy"})), now=0.0)
    with pytest.raises(TypeError):
        a.view()["b"] = {}  # type: ignore[index]
    with pytest.raises(TypeError):
        a.view()["b"]["status"] = "hacked"  # type: ignore[index]
    with pytest.raises(TypeError):
        a.properties["status"] = "hacked"  # type: ignore[index]
    assert a.view()["b"]["status"] == "busy"


def test_a_session_forms_over_bytes_and_role_messages_flow_both_ways() -> None:
    a, b, wire = pair()
    role = Recorder()
    sid = a.start_session(role, groups.within(5.0), "echo", now=0.0)
    wire.settle()
    assert role.log == [("in", "b", 0.0)]
    assert Echo.log == [("in_group_of", "b", "a")]
    [activate] = wire.frames("a", "b", ChannelData)
    assert activate == ChannelData(True, 1, 1, 0, FrameKind.ACTIVATE, ["echo", "Recorder"])
    assert role.send(ParticipantRef("b", sid), "hi")
    wire.settle()
    assert role.log[-1] == ("recv", "b", ["echo", "hi"])
    assert a.sessions()[0].members == frozenset({"b"})
    assert [p.session_id for p in b.participations()] == [sid]


def test_stop_at_a_given_time_deactivates_and_leaves_no_state() -> None:
    a, b, wire = pair(tombstone_ttl=5.0)
    role = Recorder()
    sid = a.start_session(role, groups.within(5.0), "echo", now=0.0)
    wire.settle()
    wire.now = 1.0
    a.stop_session(sid, now=1.0)
    wire.settle()
    assert Echo.log == [("in_group_of", "b", "a"), ("out_group_of", "b", "a")]
    assert role.log == [("in", "b", 0.0)]  # the role asked for the stop: no out_group
    assert a.state_counts()["sessions"] == 0
    assert b.state_counts()["tombstones"] == 1
    # The tombstone outlives a channel's retransmissions, longer than its 5 s here.
    end = 1.0 + retransmission_span(0.2, 12)
    wire.run_until(end - 0.01)
    assert b.state_counts()["tombstones"] == 1
    wire.run_until(end)
    assert set(a.state_counts().values()) == {0}
    assert set(b.state_counts().values()) == {0}
    with pytest.raises(LocalProtocolError, match="unknown session"):
        a.stop_session(sid, now=end)


def test_a_participant_that_never_acks_breaks_the_channel_and_is_removed() -> None:
    a, _, wire = pair(retransmit_timeout=0.1, max_retransmissions=4)
    role = Recorder()
    sid = a.start_session(role, groups.within(5.0), "echo", now=0.0)
    wire.settle()
    assert role.log == [("in", "b", 0.0)]
    wire.cut.add(("b", "a"))  # from now on nothing of b reaches a: no ack, no echo
    assert role.send(ParticipantRef("b", sid), "are you there?")
    wire.settle()
    wire.run_until(10.0)
    # Tries at 0.1, 0.3, 0.7 (doubling gaps); at 1.5 the fourth try is due: broken.
    data = [f for f in wire.frames("a", "b", ChannelData) if f.kind == FrameKind.ROLE]
    assert len(data) == 4  # the first send and three retransmissions
    assert role.log == [("in", "b", 0.0), ("out", "b", 1.5)]
    assert a.counters["channels_broken"] == 1
    assert a.counters["retransmissions"] == 3
    assert role.members == frozenset()
    assert a.sessions()[0].members == frozenset()
    assert not role.send(ParticipantRef("b", sid), "late")  # no member: nothing sent
    counts = a.state_counts()
    assert (counts["members"], counts["closing_channels"]) == (0, 0)
    assert a.next_deadline() is None  # the broken channel's timer is gone too
    # b is no member any more: stopping needs no acknowledgement from it.
    a.stop_session(sid, now=10.0)
    wire.settle()
    assert set(a.state_counts().values()) == {0}


def test_a_broken_participant_side_ends_the_role() -> None:
    a, b, wire = pair(retransmit_timeout=0.1, max_retransmissions=3)
    a.start_session(Recorder(), groups.within(5.0), "echo", now=0.0)
    wire.settle()
    wire.cut.add(("a", "b"))  # the initiator vanished without a word
    [participant_role] = Echo.instances
    assert participant_role.send("hello?")
    wire.run_until(10.0)
    assert Echo.log[-1] == ("out_group_of", "b", "a")
    assert b.counters["channels_broken"] == 1
    assert b.participations() == []
    assert not participant_role.send("anyone?")


def test_call_later_and_timers_run_at_exact_virtual_times() -> None:
    a = NodeMachine("a", now=2.0, config=NodeConfig(property_interval=1.0))
    fired: list[float] = []
    a.call_later(0.5, lambda: fired.append(a.now), now=2.0)
    cancelled = a.call_later(0.7, lambda: fired.append(-1.0), now=2.0)
    cancelled.cancel()
    assert a.next_deadline() == 2.5
    a.tick(2.5)
    for event in a.events_received():
        event.fn(*event.args)
    assert fired == [2.5]
    assert a.next_deadline() == 3.0  # the heartbeat; the cancelled timer is skipped
    with pytest.raises(LocalProtocolError, match="delay must be >= 0"):
        a.call_later(-1.0, lambda: None, now=3.0)


def test_bad_input_from_a_peer_is_dropped_and_counted() -> None:
    a = NodeMachine("a")
    a.receive("b", b"\x93garbage", now=0.0)
    a.receive("a", codec.encode(PropertyUpdate(1, {"x": 1})), now=0.0)  # claims to be us
    a.receive("b", codec.encode(ChannelData(False, 7, 1, 0, FrameKind.ROLE, "x")), now=0.0)
    a.receive("b", codec.encode(ChannelAck(False, 7, 1, 0)), now=0.0)
    assert a.counters == {
        "dropped_malformed": 1,
        "dropped_own": 1,
        "dropped_unknown_session": 1,
        "dropped_stray_ack": 1,
    }
    assert a.dropped_by_peer == {"b": 1}  # decoding failures are counted per peer
    assert a.view() == {}


def test_silent_nodes_fail_at_the_failure_timeout() -> None:
    a = NodeMachine("a", config=NodeConfig(failure_timeout=3.0))
    departed: Log = []
    a.observers.add_departure(lambda node, last: departed.append((node, dict(last), a.now)))
    a.receive("b", codec.encode(PropertyUpdate(1, {"status": "idle"})), now=0.5)
    now = 0.0
    while not departed and (deadline := a.next_deadline()) is not None and deadline < 10:
        now = deadline
        a.tick(now)
        for event in a.events_received():
            event.fn(*event.args)
    # Checked every timeout / 3 = 1 s: at 4.0 b has been silent for 3.5 s > 3.0.
    assert departed == [("b", {"status": "idle"}, 4.0)]
    assert a.counters["departed_failed"] == 1


def test_a_leaving_node_stops_its_sessions_and_says_goodbye() -> None:
    a, b, wire = pair()
    a.start_session(Recorder(), groups.within(5.0), "echo", now=0.0)
    wire.settle()
    b_role = Recorder()
    b.start_session(b_role, groups.within(5.0), "missing-role", now=0.0)
    wire.settle()
    a.leave(now=1.0)
    wire.settle()
    assert ("out_group_of", "b", "a") in Echo.log
    assert b.counters["departed_left"] == 1
    assert "a" not in b.view()
    assert wire.frames("a", "b", Leave) == [Leave()]


def test_send_properties_to_a_newcomer_carries_everything() -> None:
    a = NodeMachine("a")
    a.messages_to_send()
    a.update_property("status", "idle", 0.0)
    a.update_property("position", (3.0, 4.0), 0.0)
    a.messages_to_send()
    a.send_properties_to("late", now=1.0)
    [sent] = a.messages_to_send()
    assert isinstance(sent, Send)
    assert sent.target == "late"
    # The number of the latest publication: the newcomer's next one follows it.
    assert codec.decode(sent.data) == PropertyUpdate(
        1, {"status": "idle", "position": (3.0, 4.0)}, full=True
    )


def test_a_node_heard_only_in_deltas_is_asked_for_a_snapshot_once_per_retry() -> None:
    a = NodeMachine("a")
    a.messages_to_send()
    a.receive("b", codec.encode(PropertyUpdate(5, {"position": (1.0, 0.0)})), now=1.0)
    [ask] = a.messages_to_send()
    assert ask == Send("b", codec.encode(PropertyRequest()), "property")
    a.receive("b", codec.encode(PropertyUpdate(6, {"position": (2.0, 0.0)})), now=1.5)
    assert a.messages_to_send() == []  # the answer may still be on its way
    a.receive("b", codec.encode(PropertyUpdate(7, {"position": (3.0, 0.0)})), now=2.0)
    assert a.messages_to_send() == [ask]  # SNAPSHOT_RETRY (1 s) later: ask again
    a.receive("b", codec.encode(PropertyUpdate(4, {"hull_length": 2.0}, full=True)), now=2.1)
    a.receive("b", codec.encode(PropertyUpdate(8, {"position": (4.0, 0.0)})), now=5.0)
    assert a.messages_to_send() == []  # complete now: deltas are enough
    assert a.view()["b"] == {"position": (4.0, 0.0), "hull_length": 2.0}


def test_a_delta_after_a_missed_publication_asks_for_a_snapshot() -> None:
    a = NodeMachine("a")
    a.messages_to_send()
    a.receive("b", codec.encode(PropertyUpdate(3, {"hull_length": 1.0}, full=True)), now=1.0)
    a.receive("b", codec.encode(PropertyUpdate(4, {"position": (1.0, 0.0)})), now=1.1)
    a.receive("b", codec.encode(PropertyUpdate(4, {"position": (1.0, 0.0)})), now=1.2)
    assert a.messages_to_send() == []  # one after the other, and a repeat: nothing lost
    # 5 (a grown hull, say) was lost: 6 changes only the position.
    a.receive("b", codec.encode(PropertyUpdate(6, {"position": (2.0, 0.0)})), now=1.3)
    assert a.messages_to_send() == [Send("b", codec.encode(PropertyRequest()), "property")]
    assert a.counters["publications_missed"] == 1
    a.receive("b", codec.encode(PropertyUpdate(6, {"hull_length": 9.0}, full=True)), now=1.4)
    assert a.view()["b"]["hull_length"] == 9.0
    a.receive("b", codec.encode(PropertyUpdate(7, {"position": (3.0, 0.0)})), now=1.5)
    assert a.messages_to_send() == []  # whole again


def test_a_request_is_answered_with_a_snapshot_to_the_asker_alone() -> None:
    b = NodeMachine("b")
    b.update_property("status", "idle", now=0.0)
    b.update_property("hull_length", 2.0, now=0.0)
    b.messages_to_send()
    b.receive("a", codec.encode(PropertyRequest()), now=1.0)
    [answer] = b.messages_to_send()
    assert isinstance(answer, Send)
    assert answer.target == "a"
    assert codec.decode(answer.data) == PropertyUpdate(
        1, {"status": "idle", "hull_length": 2.0}, full=True
    )


def test_a_missed_hull_length_is_repaired_within_one_round_trip_without_heartbeat() -> None:
    a, b = NodeMachine("a"), NodeMachine("b")
    wire = Wire(a, b)
    wire.cut.add(("b", "a"))
    b.update_property("position", (1.0, 0.0), now=0.0)
    b.update_property("hull_length", 2.5, now=0.0)
    wire.settle()  # lost on the way: a never heard of b
    wire.cut.clear()
    b.update_property("position", (1.5, 0.0), now=1.0)  # a delta: position only
    wire.settle()
    assert a.view()["b"] == {"position": (1.5, 0.0), "hull_length": 2.5}
    asks = wire.frames("a", "b", PropertyRequest)
    assert asks == [PropertyRequest()]
