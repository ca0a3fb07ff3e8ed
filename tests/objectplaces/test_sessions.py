"""Interaction sessions: formation, maintenance, channels, stop, and the guarantees."""

from __future__ import annotations

import logging
from typing import Any

import pytest

from objectplaces import Initiator, LocalProtocolError, Participant, ParticipantRef, groups
from objectplaces.core import codec
from objectplaces.core.channel import retransmission_span
from objectplaces.core.messages import ChannelData, FrameKind
from objectplaces.sim import SimulatedNetwork

from .recording import Event, RecordingInitiator, RecordingParticipant, place

NETWORKS = {
    "ideal": {"delay": 0.005},
    "jitter": {"delay": 0.01, "jitter": 0.009},
    "lossy": {"delay": 0.01, "jitter": 0.005, "loss": 0.2, "duplicate": 0.1, "reorder": 0.2},
}


def fleet(net: SimulatedNetwork, names: str, log: list[Event]) -> dict[str, Any]:
    nodes = {}
    for i, name in enumerate(names):
        node = net.add_node(name)
        node.set_participant_factory("voter", lambda: RecordingParticipant(log))
        place(node, 10.0 * i, 0.0)
        nodes[name] = node
    return nodes


def all_state(net: SimulatedNetwork) -> dict[str, int]:
    total: dict[str, int] = {}
    for node in net.nodes.values():
        for key, value in node.machine.state_counts().items():
            total[key] = total.get(key, 0) + value
    return total


@pytest.mark.parametrize("conditions", NETWORKS.values(), ids=NETWORKS.keys())
def test_group_forms_and_follows_movement(conditions: dict[str, Any]) -> None:
    net = SimulatedNetwork(seed=11, property_interval=0.5, **conditions)
    log: list[Event] = []
    n = fleet(net, "abcd", log)
    place(n["b"], 1.5, 0.0)
    net.run_for(1.0)
    role = RecordingInitiator()
    n["a"].start_interaction(role, groups.circles_overlap(), "voter")
    net.run_for(1.0)
    assert role.membership() == [("in", "b")]
    place(n["c"], 0.0, 1.9)  # c walks in
    net.run_for(1.0)
    place(n["b"], 2.1, 0.0)  # b walks out
    # Under 20% loss the update may need a republication or two (every 0.5 s) to arrive.
    net.run_for(2.0)
    assert role.membership() == [("in", "b"), ("in", "c"), ("out", "b")]
    assert role.members == frozenset({ParticipantRef("c", role.session_id)})
    assert ("b", "out_group_of", "a") in log
    assert ("c", "in_group_of", "a") in log
    assert ("d", "in_group_of", "a") not in log


def test_initiator_moving_changes_the_group_too() -> None:
    net = SimulatedNetwork(seed=12)
    log: list[Event] = []
    n = fleet(net, "abc", log)
    net.run_for(0.1)
    role = RecordingInitiator()
    n["a"].start_interaction(role, groups.within(3.0), "voter")
    net.run_for(0.1)
    assert role.membership() == []
    place(n["a"], 9.0, 0.0)
    net.run_for(0.1)
    place(n["a"], 19.0, 0.0)
    net.run_for(0.1)
    assert role.membership() == [("in", "b"), ("out", "b"), ("in", "c")]


def test_a_node_without_the_role_declines_and_the_initiator_never_hears_of_it() -> None:
    net = SimulatedNetwork(seed=13)
    log: list[Event] = []
    n = fleet(net, "ab", log)
    plain = net.add_node("plain")  # no factory registered
    place(plain, 0.5, 0.0)
    place(n["b"], 1.0, 0.0)
    net.run_for(0.1)
    role = RecordingInitiator()
    n["a"].start_interaction(role, groups.circles_overlap(), "voter")
    net.run_for(0.5)
    place(plain, 0.6, 0.0)  # still matching: no second activation attempt
    net.run_for(0.5)
    assert role.membership() == [("in", "b")]
    sent = plain.stats().sent["channel"][0]
    assert sent == 1  # exactly one DECLINED
    assert plain.participations() == []


def test_guarantee_1_a_vote_in_flight_from_a_leaving_voter_is_dropped() -> None:
    net = SimulatedNetwork(seed=14, delay=0.01)
    shared: list[Event] = []

    class SlowVoter(Participant):
        def in_group_of(self, initiator: Any) -> None:
            self.call_later(0.3, lambda: self.send("allow"))

    a, b = net.add_node("a"), net.add_node("b")
    b.set_participant_factory("voter", SlowVoter)
    place(a, 0, 0)
    place(b, 1, 0)
    net.run_for(0.1)
    role = RecordingInitiator()
    a.start_interaction(role, groups.circles_overlap(), "voter")
    net.run_for(0.1)
    assert role.membership() == [("in", "b")]
    net.set_link("b", "a", both_ways=False, delay=0.5)  # the vote will be slow
    net.run_for(0.25)  # b sends its vote at ~0.42; it arrives at ~0.92
    place(a, 50, 0)  # a moves away before the vote arrives: b leaves the group
    net.run_for(2.0)
    assert role.membership() == [("in", "b"), ("out", "b")]
    assert role.received() == []
    assert a.stats().counters.get("dropped_non_member", 0) >= 1
    assert shared == []


def test_messages_never_cross_sessions_even_with_the_same_participant() -> None:
    net = SimulatedNetwork(seed=15)
    log: list[Event] = []

    class Echo(Participant):
        def receive(self, message: Any) -> None:
            self.send({"echo": message, "session": self.session_id})

    a, b = net.add_node("a"), net.add_node("b")
    b.set_participant_factory("echo", Echo)
    place(a, 0, 0)
    place(b, 1, 0)
    net.run_for(0.1)
    first, second = RecordingInitiator(greeting="one"), RecordingInitiator(greeting="two")
    s1 = a.start_interaction(first, groups.within(5), "echo")
    s2 = a.start_interaction(second, groups.within(5), "echo")
    net.run_for(0.5)
    assert first.received() == [("b", {"echo": "one", "session": s1.session_id})]
    assert second.received() == [("b", {"echo": "two", "session": s2.session_id})]
    assert len(b.participations()) == 2
    assert log == []


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_channels_are_reliable_and_fifo_over_a_bad_network(seed: int) -> None:
    net = SimulatedNetwork(
        seed=seed,
        delay=0.01,
        jitter=0.01,
        loss=0.3,
        duplicate=0.2,
        reorder=0.3,
        property_interval=0.2,
        failure_timeout=30.0,
    )
    received: list[Any] = []

    class Counter(Participant):
        def receive(self, message: Any) -> None:
            received.append(message)
            self.send(message)

    class Burst(RecordingInitiator):
        def in_group(self, participant: ParticipantRef) -> None:
            super().in_group(participant)
            for i in range(100):
                self.send(participant, i)

    a, b = net.add_node("a"), net.add_node("b")
    b.set_participant_factory("counter", Counter)
    place(a, 0, 0)
    place(b, 1, 0)
    net.run_for(1.0)
    role = Burst()
    a.start_interaction(role, groups.within(5), "counter")
    assert net.run_until(lambda: len(role.received()) == 100, timeout=120.0)
    net.run_for(5.0)
    assert received == list(range(100))
    assert [m for _, m in role.received()] == list(range(100))
    assert a.stats().counters.get("retransmissions", 0) > 0


@pytest.mark.parametrize("conditions", NETWORKS.values(), ids=NETWORKS.keys())
def test_stop_deactivates_everyone_and_leaves_no_state(conditions: dict[str, Any]) -> None:
    net = SimulatedNetwork(seed=16, property_interval=0.5, failure_timeout=60.0, **conditions)
    log: list[Event] = []
    n = fleet(net, "abcde", log)
    for i, name in enumerate("bcde"):
        place(n[name], 0.5 * (i + 1), 0.0)
    net.run_for(1.0)
    role = RecordingInitiator(greeting="hello")
    session = n["a"].start_interaction(role, groups.circles_overlap(), "voter")
    net.run_for(2.0)
    assert sorted(e[2] for e in role.log if e[1] == "in") == list("bcde")
    n["a"].stop_interaction(session)
    net.run_for(3.0)
    assert sorted(e[0] for e in log if e[1] == "out_group_of") == list("bcde")
    assert n["a"].sessions() == []
    config = n["b"].machine.config  # tombstones of closed channels expire too, once no
    net.run_for(retransmission_span(config.retransmit_timeout, config.max_retransmissions))
    assert set(all_state(net).values()) == {0}
    with pytest.raises(LocalProtocolError, match="unknown session"):
        n["a"].stop_interaction(session)


def test_a_node_folds_initiator_and_participant_roles() -> None:
    net = SimulatedNetwork(seed=17)
    log: list[Event] = []
    n = fleet(net, "abc", log)
    place(n["b"], 1, 0)
    place(n["c"], 0, 1)
    net.run_for(0.1)
    roles = {name: RecordingInitiator() for name in "abc"}
    for name, role in roles.items():
        n[name].start_interaction(role, groups.circles_overlap(), "voter")
    extra = RecordingInitiator()
    n["a"].start_interaction(extra, groups.circles_overlap(), "voter")
    net.run_for(0.5)
    for name, role in roles.items():
        assert sorted(node for _, node in role.membership()) == sorted(set("abc") - {name})
    assert sorted(node for _, node in extra.membership()) == ["b", "c"]
    assert len(n["b"].participations()) == 3  # for a twice, and for c
    assert len(n["a"].sessions()) == 2


def test_view_group_answers_locally_without_messages() -> None:
    net = SimulatedNetwork(seed=18)
    log: list[Event] = []
    n = fleet(net, "abcd", log)
    place(n["b"], 1, 0)
    net.run_for(0.1)
    before = net.stats().messages
    assert n["a"].view_group(groups.circles_overlap()) == frozenset({"b"})
    assert n["a"].view_group(lambda mine, theirs: theirs["position"][0] > 15) == frozenset(
        {"c", "d"}
    )
    assert net.stats().messages == before


def test_a_raising_role_is_logged_and_the_node_goes_on(caplog: pytest.LogCaptureFixture) -> None:
    net = SimulatedNetwork(seed=19)
    log: list[Event] = []

    class Broken(Initiator):
        def in_group(self, participant: ParticipantRef) -> None:
            raise RuntimeError("boom")

    n = fleet(net, "ab", log)
    place(n["b"], 1, 0)
    net.run_for(0.1)
    with caplog.at_level(logging.ERROR, logger="objectplaces"):
        broken = n["a"].start_interaction(Broken(), groups.within(5), "voter")
        healthy = RecordingInitiator()
        n["a"].start_interaction(healthy, groups.within(5), "voter")
        net.run_for(0.5)
    assert healthy.membership() == [("in", "b")]
    assert any(broken.session_id in record.getMessage() for record in caplog.records)


def test_a_frame_for_an_unknown_session_is_dropped_and_counted() -> None:
    net = SimulatedNetwork(seed=20)
    a = net.add_node("a")
    frame = codec.encode(ChannelData(False, 999, 1, 0, FrameKind.ROLE, "stray"))
    a.machine.receive("x", frame, net.now)
    a.machine.receive("x", b"\x93garbage", net.now)
    assert a.stats().counters["dropped_unknown_session"] == 1
    assert a.stats().counters["dropped_malformed"] == 1


def test_failure_timeout_removes_a_crashed_participant_and_initiator() -> None:
    net = SimulatedNetwork(seed=21, property_interval=0.5)
    log: list[Event] = []
    n = fleet(net, "abc", log)
    place(n["b"], 1, 0)
    net.run_for(1.0)
    role = RecordingInitiator()
    n["a"].start_interaction(role, groups.circles_overlap(), "voter")
    c_role = RecordingInitiator()
    place(n["c"], 0, 1.5)
    net.run_for(0.5)
    n["c"].start_interaction(c_role, groups.circles_overlap(), "voter")
    net.run_for(0.5)
    crashed_at = net.now
    net.remove_node("b")
    net.run_until(lambda: ("out", "b") in role.membership(), timeout=5.0)
    assert ("out", "b") in role.membership()
    assert net.now - crashed_at <= 1.5 + 0.5 + 0.05  # failure timeout + one check period
    net.remove_node("c")  # a's participant role in c's session must go too
    net.run_for(2.5)
    assert ("a", "out_group_of", "c") in log
    assert n["a"].participations() == []


@pytest.mark.source_only("arguments of the wrong type")
def test_bad_session_arguments_fail_clearly() -> None:
    net = SimulatedNetwork()
    a = net.add_node("a")
    with pytest.raises(LocalProtocolError, match="must subclass Initiator"):
        a.start_interaction(object(), groups.within(1), "voter")  # type: ignore[arg-type]
    with pytest.raises(LocalProtocolError, match="must be callable"):
        a.start_interaction(RecordingInitiator(), 42, "voter")  # type: ignore[arg-type]
    with pytest.raises(LocalProtocolError, match="non-empty string"):
        a.start_interaction(RecordingInitiator(), groups.within(1), "")
    role = RecordingInitiator()
    a.start_interaction(role, groups.within(1), "voter")
    with pytest.raises(LocalProtocolError, match="already plays"):
        a.start_interaction(role, groups.within(1), "voter")
    with pytest.raises(LocalProtocolError, match="not active"):
        RecordingInitiator().send(ParticipantRef("b", "a#1"), "x")


def test_same_seed_same_run() -> None:
    def run() -> tuple[list[Event], int]:
        net = SimulatedNetwork(
            seed=99, delay=0.01, jitter=0.01, loss=0.1, reorder=0.1, property_interval=0.5
        )
        log: list[Event] = []
        n = fleet(net, "abcdef", log)
        role = RecordingInitiator(greeting=1)
        n["a"].start_interaction(role, groups.circles_overlap(), "voter")
        for step in range(30):
            for i, name in enumerate("bcdef"):
                place(n[name], 10.0 * (i + 1) - step * 0.7 * (i + 1), 0.0, 1.0)
            net.run_for(0.3)
        return role.log, net.stats().bytes

    assert run() == run()


def test_a_restarted_node_counts_at_once_with_its_properties_and_sessions() -> None:
    net = SimulatedNetwork(seed=22, property_interval=0.5, failure_timeout=30.0)
    log: list[Event] = []
    n = fleet(net, "ab", log)
    place(n["b"], 1, 0)
    net.run_for(1.0)
    old = RecordingInitiator()
    n["b"].start_interaction(old, groups.within(5), "voter")
    net.run_for(1.0)
    assert old.membership() == [("in", "a")]
    net.remove_node("b")  # crash, then come back long before the failure timeout
    net.run_for(1.0)
    b = net.add_node("b")
    place(b, 2, 0, 1.0)
    net.run_for(0.1)
    assert n["a"].view()["b"]["position"] == (2.0, 0.0)  # new sequence numbers count
    assert ("a", "out_group_of", "b") in log  # the old run's session is gone
    new = RecordingInitiator()
    session = b.start_interaction(new, groups.within(5), "voter")
    assert session.session_id == "b#1"  # the same number as the old run's session
    net.run_for(0.2)
    assert new.membership() == [("in", "a")]


def one_way_pair(seed: int) -> tuple[SimulatedNetwork, RecordingInitiator, list[Event], str]:
    net = SimulatedNetwork(seed=seed, property_interval=0.5, failure_timeout=1.5)
    log: list[Event] = []
    n = fleet(net, "ab", log)
    place(n["b"], 1, 0)
    role = RecordingInitiator()
    session = n["a"].start_interaction(role, groups.within(5.0), "voter")
    net.run_for(1.0)
    assert role.membership() == [("in", "b")]
    return net, role, log, session.session_id


def test_a_participant_that_took_its_initiator_for_failed_does_not_stay_a_member() -> None:
    net, role, log, sid = one_way_pair(seed=23)
    a, b = net.node("a"), net.node("b")
    net.set_link("a", "b", both_ways=False, loss=1.0)  # b hears nothing of a; a hears b
    net.run_for(3.0)
    assert ("b", "out_group_of", "a") in log  # b's failure detector ended the role
    assert ("out", "b") in role.membership()  # and b said so (LEFT): a dropped it
    net.set_link("a", "b", both_ways=False, loss=0.0)
    net.run_for(5.0)  # b still matches: activated afresh once a reaches it again
    assert role.membership()[-1] == ("in", "b")
    assert [p.session_id for p in b.participations()] == [sid]
    [member] = role.members
    assert role.send(member, "hello")
    net.run_for(1.0)
    assert log[-1] == ("b", "receive", "hello")
    assert {i.session_id: i.members for i in a.sessions()}[sid] == {"b"}


def test_a_participant_taken_for_failed_is_deactivated_if_it_still_hears() -> None:
    net, role, log, sid = one_way_pair(seed=24)
    a, b = net.node("a"), net.node("b")
    net.set_link("b", "a", both_ways=False, loss=1.0)  # a hears nothing of b; b hears a
    net.run_for(3.0)
    assert role.members == frozenset()  # a's failure detector dropped b
    assert ("b", "out_group_of", "a") in log  # and the DEACTIVATE reached b all the same
    a.stop_interaction(sid)
    net.set_link("b", "a", both_ways=False, loss=0.0)
    net.run_for(60.0)  # every retransmission, failure timeout and tombstone is over
    assert b.participations() == []
    assert set(a.machine.state_counts().values()) == {0}
    assert set(b.machine.state_counts().values()) == {0}


def test_a_lost_left_is_repeated_until_the_initiator_hears_it() -> None:
    net = SimulatedNetwork(seed=25, property_interval=0.5)
    log: list[Event] = []
    a = net.add_node("a", failure_timeout=100.0)  # a never takes b for failed
    b = net.add_node("b", failure_timeout=1.5)
    b.set_participant_factory("voter", lambda: RecordingParticipant(log))
    place(a, 0, 0)
    place(b, 1, 0)
    role = RecordingInitiator()
    sid = a.start_interaction(role, groups.within(5.0), "voter").session_id
    net.run_for(1.0)
    assert role.membership() == [("in", "b")]
    net.set_link("a", "b", loss=1.0)  # b takes a for failed; its first LEFT is lost
    net.run_for(3.0)
    assert ("b", "out_group_of", "a") in log
    assert role.membership() == [("in", "b")]  # a, idle, sends nothing that b could answer
    net.set_link("a", "b", loss=0.0)
    net.run_for(5.0)  # a repeated LEFT arrives: a drops b and, as b matches, activates it
    assert role.membership() == [("in", "b"), ("out", "b"), ("in", "b")]
    assert [p.session_id for p in b.participations()] == [sid]

    def sent_by_b() -> int:
        return net.stats().per_node["b"].sent.get("channel", [0])[0]

    before = sent_by_b()
    net.run_for(4.0)  # longer than the longest backoff, within the tombstone's life
    assert sent_by_b() == before  # b says LEFT no more
