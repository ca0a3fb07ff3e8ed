"""A role that acts outside its callbacks (from the application's own code) is heard at
once and stamps its commands with the current time, not its node's last input's."""

from __future__ import annotations

from typing import Any

from objectplaces import groups
from objectplaces.sim import SimulatedNetwork

from .recording import Event, RecordingInitiator, RecordingParticipant, place

HEARTBEAT = 5.0  # long, so that no input of the network drains the sender by chance


def pair(
    net: SimulatedNetwork, log: list[Event], made: list[RecordingParticipant]
) -> tuple[Any, Any]:
    a, b = net.add_node("a"), net.add_node("b")

    def voter() -> RecordingParticipant:
        made.append(RecordingParticipant(log))
        return made[-1]

    b.set_participant_factory("voter", voter)
    place(a, 0.0, 0.0)
    place(b, 1.0, 0.0)
    return a, b


def joined_session(
    net: SimulatedNetwork, log: list[Event], made: list[RecordingParticipant] | None = None
) -> RecordingInitiator:
    a, _b = pair(net, log, [] if made is None else made)
    net.run_for(0.5)
    role = RecordingInitiator()
    a.start_interaction(role, groups.circles_overlap(), "voter")
    assert net.run_until(lambda: role.membership() == [("in", "b")], timeout=1.0)
    net.run_for(0.5)  # every ack in: the sender's machine has no input left to come
    return role


def test_initiator_send_outside_a_callback_leaves_at_once() -> None:
    net = SimulatedNetwork(seed=3, delay=0.005, property_interval=HEARTBEAT)
    log: list[Event] = []
    role = joined_session(net, log)
    (member,) = role.members
    assert role.send(member, "go")
    net.run_for(0.1)
    assert ("b", "receive", "go") in log


def test_participant_send_outside_a_callback_leaves_at_once() -> None:
    net = SimulatedNetwork(seed=4, delay=0.005, property_interval=HEARTBEAT)
    log: list[Event] = []
    made: list[RecordingParticipant] = []
    role = joined_session(net, log, made)
    (voter,) = made
    assert voter.send("ready")
    net.run_for(0.1)
    assert role.received() == [("b", "ready")]


def test_timer_set_outside_a_callback_counts_from_now() -> None:
    net = SimulatedNetwork(seed=5, delay=0.005, property_interval=HEARTBEAT)
    log: list[Event] = []
    role = joined_session(net, log)
    net.run_for(2.0)  # no input reaches the initiator's node in these two seconds
    fired: list[float] = []
    set_at = net.now
    role.call_later(1.0, lambda: fired.append(net.now))
    net.run_for(2.0)
    assert fired == [set_at + 1.0]
