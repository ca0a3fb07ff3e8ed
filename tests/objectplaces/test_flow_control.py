"""Channels have flow control, and a message fails where it is sent (issue 10, items 2-3)."""

from __future__ import annotations

import os
from typing import Any

import pytest

from objectplaces import Participant, ParticipantRef, groups
from objectplaces.sim import SimulatedNetwork

from .recording import RecordingInitiator, place

SEED = int(os.environ.get("OP_SEED", "5"))


class Collector(Participant):
    """Keeps every message; can answer in bursts of its own."""

    received: list[Any]

    def __init__(self, burst: int = 0) -> None:
        self.received = []
        self.burst = burst

    def in_group_of(self, initiator: Any) -> None:
        for i in range(self.burst):
            assert self.send(i)

    def receive(self, message: Any) -> None:
        self.received.append(message)


def sink(collectors: list[Collector], burst: int = 0) -> Any:
    """A factory that keeps the roles it makes."""

    def make() -> Collector:
        collectors.append(Collector(burst))
        return collectors[-1]

    return make


def pair(seed: int, **conditions: Any) -> tuple[Any, Any, SimulatedNetwork]:
    net = SimulatedNetwork(seed=seed, delay=0.01, **conditions)
    a, b = net.add_node("a"), net.add_node("b")
    place(a, 0, 0)
    place(b, 1, 0)
    net.run_for(0.1)
    return a, b, net


def test_a_burst_of_5000_over_a_lossy_link_arrives_whole_and_in_order() -> None:
    print(f"OP_SEED={SEED}")
    a, b, net = pair(SEED, loss=0.05)
    collectors: list[Collector] = []
    b.set_participant_factory("sink", sink(collectors))

    class Burst(RecordingInitiator):
        def in_group(self, participant: ParticipantRef) -> None:
            super().in_group(participant)
            for i in range(5000):
                assert self.send(participant, i)  # all of it is taken: the buffer holds it

    role = Burst()
    a.start_interaction(role, groups.within(5.0), "sink")
    assert net.run_until(
        lambda: bool(collectors) and len(collectors[0].received) == 5000, timeout=600.0
    )
    assert collectors[0].received == list(range(5000))
    assert role.membership() == [("in", "b")]  # the healthy member stayed
    counters = a.stats().counters
    assert counters.get("channels_broken", 0) == 0
    assert counters["retransmissions"] > 0  # the loss was real


def test_a_participants_burst_reaches_the_initiator_too() -> None:
    a, b, net = pair(SEED + 1, loss=0.05)
    b.set_participant_factory("talker", lambda: Collector(burst=3000))
    role = RecordingInitiator()
    a.start_interaction(role, groups.within(5.0), "talker")
    assert net.run_until(lambda: len(role.received()) == 3000, timeout=600.0)
    assert [m for _, m in role.received()] == list(range(3000))
    assert b.stats().counters.get("channels_broken", 0) == 0


def test_a_full_send_buffer_makes_send_return_false_and_nothing_is_lost() -> None:
    a, b, net = pair(SEED + 2)
    collectors: list[Collector] = []
    b.set_participant_factory("sink", sink(collectors))
    accepted: list[bool] = []

    class Flood(RecordingInitiator):
        def in_group(self, participant: ParticipantRef) -> None:
            super().in_group(participant)
            accepted.extend(self.send(participant, i) for i in range(10_256 + 500))

    a.start_interaction(Flood(), groups.within(5.0), "sink")
    net.run_for(120.0)
    # The window (256) went out at once; 10,000 more waited; the rest was refused.
    assert accepted == [True] * 10_256 + [False] * 500
    assert collectors[0].received == list(range(10_256))
    assert a.stats().counters["send_buffer_full"] == 500


def test_send_refuses_what_is_not_plain_data_at_the_call() -> None:
    a, b, net = pair(SEED + 3, property_interval=0.5, failure_timeout=30.0)
    collectors: list[Collector] = []
    b.set_participant_factory("sink", sink(collectors))
    role = RecordingInitiator()
    a.start_interaction(role, groups.within(5.0), "sink")
    net.run_for(0.5)
    [member] = role.members
    with pytest.raises(TypeError, match="not serialisable"):
        role.send(member, {"obj": object()})
    assert role.send(member, "after")
    with pytest.raises(TypeError):
        collectors[0].send({"obj": object()})
    assert collectors[0].send("back")
    net.run_for(30.0)  # retransmission timers run: nothing surfaces later
    assert collectors[0].received == ["after"]
    assert role.received() == [("b", "back")]
    assert net.stats().dropped["failed"] == 0
    assert role.membership() == [("in", "b")]
