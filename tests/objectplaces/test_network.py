"""The simulated network itself: partitions, crashes, statistics, argument checks."""

from __future__ import annotations

import logging
from typing import Any

import msgpack
import pytest

from objectplaces import LocalProtocolError, groups
from objectplaces.sim import SimulatedNetwork

from .recording import Event, RecordingInitiator, RecordingParticipant, place


def test_a_partition_splits_groups_and_healing_restores_them() -> None:
    net = SimulatedNetwork(seed=31, delay=0.01, property_interval=0.5)
    log: list[Event] = []
    a, b = net.add_node("a"), net.add_node("b")
    b.set_participant_factory("voter", lambda: RecordingParticipant(log))
    place(a, 0, 0)
    place(b, 1, 0)
    net.run_for(1.0)
    role = RecordingInitiator()
    a.start_interaction(role, groups.within(5), "voter")
    net.run_for(0.5)
    net.partition({"a"}, {"b"})
    net.run_for(2.5)  # failure timeout (1.5 s) plus a liveness check
    assert role.membership() == [("in", "b"), ("out", "b")]
    assert ("b", "out_group_of", "a") in log
    assert net.stats().dropped["partition"] > 0
    net.heal()
    net.run_for(1.5)  # b's next republication reaches a again
    assert role.membership() == [("in", "b"), ("out", "b"), ("in", "b")]


def test_unnamed_nodes_form_one_more_partition_group() -> None:
    net = SimulatedNetwork(seed=32)
    a, b, c = (net.add_node(n) for n in "abc")
    net.partition({"a"})
    b.update_node_property("status", "up")
    net.run_for(0.1)
    assert "b" in c.view()
    assert "b" not in a.view()
    with pytest.raises(LocalProtocolError, match="two partition groups"):
        net.partition({"a"}, {"a", "b"})


def test_stats_count_frames_and_bytes_per_node_and_kind() -> None:
    net = SimulatedNetwork(seed=33)
    a, b, _c = (net.add_node(n) for n in "abc")
    net.run_for(0.1)  # start-up: subscriptions and their syncs
    place(a, 0, 0)
    net.run_for(0.1)
    stats = net.stats()
    # one coalesced update, one frame to each of the two peers
    assert stats.per_node["a"].sent["property"][0] == 2
    assert stats.per_node["b"].received["property"][0] == 1
    assert stats.per_node["c"].received_bytes == stats.per_node["a"].sent_bytes // 2
    assert stats.by_kind["property"] == (2, stats.per_node["a"].sent_bytes)
    assert stats.delivered == 2
    assert a.stats().messages_sent == 2
    assert b.stats().messages_received == 1


def test_crashed_node_receives_nothing_more_and_ids_are_checked() -> None:
    net = SimulatedNetwork(seed=34, delay=0.05)
    a, _ = net.add_node("a"), net.add_node("b")
    a.update_node_property("status", "x")
    net.run_for(0.01)  # the frame is in flight
    net.remove_node("b")
    net.run_for(0.1)
    assert net.stats().dropped["dead"] == 1
    with pytest.raises(LocalProtocolError, match="unknown node"):
        net.remove_node("b")
    with pytest.raises(LocalProtocolError, match="unknown node"):
        net.node("b")
    with pytest.raises(LocalProtocolError, match="probability"):
        SimulatedNetwork(loss=1.5)
    with pytest.raises(LocalProtocolError, match="interest_radius"):
        net.add_node("c", interest_radius=0)


def test_a_crashed_node_loses_what_it_had_in_flight() -> None:
    net = SimulatedNetwork(seed=37, delay=0.05)
    a, b = net.add_node("a"), net.add_node("b")
    b.update_node_property("status", "x")
    net.run_for(0.01)  # the frame is in flight
    net.remove_node("b")
    net.run_for(0.1)
    assert "b" not in a.view()
    assert net.stats().dropped["dead"] == 1


def test_an_old_run_s_frames_in_flight_never_reach_the_new_run_s_peers() -> None:
    net = SimulatedNetwork(seed=38, delay=0.05)
    log: list[Event] = []
    a, b = net.add_node("a"), net.add_node("b")
    a.set_participant_factory("voter", lambda: RecordingParticipant(log))
    place(a, 0, 0)
    place(b, 1, 0)
    net.run_for(1.0)
    b.start_interaction(RecordingInitiator(), groups.within(5.0), "voter")
    net.leave("b")  # gracefully, with the ACTIVATE still on its way
    net.add_node("b")  # and back at once, as a new run
    net.run_for(1.0)
    assert log == []  # no role for a session of the old run
    assert a.participations() == []


def test_run_until_stops_at_the_first_event_that_satisfies_the_predicate() -> None:
    net = SimulatedNetwork(seed=35, delay=0.25)
    a, b = net.add_node("a"), net.add_node("b")
    a.update_node_property("status", "x")
    assert net.run_until(lambda: "a" in b.view(), timeout=5.0)
    assert net.now == pytest.approx(0.25)
    assert not net.run_until(lambda: False, timeout=1.0)
    assert net.now == pytest.approx(1.25)


def test_graceful_leave_tells_peers_at_once() -> None:
    net = SimulatedNetwork(seed=36)
    a, b = net.add_node("a"), net.add_node("b")
    gone: list[str] = []
    a.register_node_departure_observer(lambda node, last: gone.append(node))
    b.update_node_property("status", "x")
    net.run_for(0.1)
    net.leave("b")
    net.run_for(0.1)
    assert gone == ["b"]


def test_injected_garbage_and_a_malformed_property_frame_leave_the_target_running(
    caplog: pytest.LogCaptureFixture,
) -> None:
    net = SimulatedNetwork(seed=37, delay=0.02)
    log: list[Event] = []
    a, c = net.add_node("a"), net.add_node("c")
    c.set_participant_factory("voter", lambda: RecordingParticipant(log))
    place(a, 0, 0)
    role = RecordingInitiator()
    a.start_interaction(role, groups.within(5), "voter")  # a indexes positions
    net.run_for(0.1)
    hostile = [
        b"\x93garbage",
        b"",
        msgpack.packb([1, 1, {"position": ["x", "y"]}]),
        msgpack.packb([1, 2, {"position": [float("nan"), 0.0]}]),
        msgpack.packb([1, 3, {"position": [None, 1]}, "extra"]),
    ]
    with caplog.at_level(logging.WARNING, logger="objectplaces"):
        for data in hostile:
            net.inject("evil", "a", data)
        net.run_for(0.015)
        assert net.stats().by_kind["injected"][0] == len(hostile)
        assert net.stats().per_node["a"].received.get("injected") is None  # still in flight
        net.run_for(0.01)  # the link's delay (0.02 s) has passed
    assert net.stats().per_node["a"].received["injected"][0] == len(hostile)
    assert a.stats().counters["dropped_malformed"] == 3
    # each hostile frame was refused by the machine or, when handling it raised, dropped
    refused = sum(v for k, v in a.stats().counters.items() if k.startswith("dropped"))
    assert refused + net.stats().dropped["failed"] == len(hostile)
    # a keeps running: c walks in and is followed as before
    place(c, 1, 0)
    net.run_for(0.5)
    assert role.membership() == [("in", "c")]
    assert ("c", "in_group_of", "a") in log
    with pytest.raises(LocalProtocolError, match="unknown node 'zz'"):
        net.inject("evil", "zz", b"")


@pytest.mark.source_only("replaces NodeMachine.receive_message")
def test_a_frame_whose_handling_raises_is_dropped_and_counted(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    net = SimulatedNetwork(seed=38)
    a, b = net.add_node("a"), net.add_node("b")
    receive = a.machine.receive_message
    failures: list[str] = []

    def receive_failing_once(source: str, message: Any, now: float, *, size: int = 0) -> None:
        if not failures:  # a fault in the node's handling of this one frame
            failures.append(source)
            raise RuntimeError("poisoned")
        receive(source, message, now, size=size)

    monkeypatch.setattr(a.machine, "receive_message", receive_failing_once)
    with caplog.at_level(logging.ERROR, logger="objectplaces"):
        b.update_node_property("status", "first")
        net.run_for(0.1)
    assert failures == ["b"]
    assert net.stats().dropped["failed"] == 1
    assert any("poisoned" in r.exc_text for r in caplog.records if r.exc_text)
    b.update_node_property("status", "second")
    net.run_for(0.1)
    assert a.view()["b"]["status"] == "second"
