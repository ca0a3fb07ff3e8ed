"""The edges of the public API: why a participant left, releasing one participant,
members in a fixed order, one ``call_later`` contract, the simulator's failure
detection by default, and the tuplespace as a property of the node."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from typing import ClassVar

import pytest

from objectplaces import (
    Initiator,
    LocalProtocolError,
    MemberSet,
    OutReason,
    Participant,
    ParticipantRef,
    TimerHandle,
    groups,
)
from objectplaces.sim import SimulatedNetwork
from tuplespace import TupleSpace


class Recorder(Participant):
    log: ClassVar[list[tuple[str, str, OutReason | None]]] = []

    def out_group_of(self, initiator: object) -> None:
        Recorder.log.append((self.node_id, self.session_id, self.out_reason))


def line(n: int, **options: object) -> SimulatedNetwork:
    """Nodes n0..n{n-1} on a line 1 m apart, each able to play "recorder"."""
    Recorder.log = []
    net = SimulatedNetwork(seed=5, **options)  # type: ignore[arg-type]
    for i in range(n):
        node = net.add_node(f"n{i}")
        node.update_node_property("position", (float(i), 0.0))
        node.set_participant_factory("recorder", Recorder)
    net.run_for(0.5)
    return net


def test_out_group_of_is_told_why() -> None:
    net = line(4)
    n0 = net.node("n0")
    role = Initiator()
    session = n0.start_interaction(role, groups.within(2.5), "recorder")
    net.run_for(0.5)
    assert [m.node_id for m in role.members] == ["n1", "n2"]
    net.node("n2").update_node_property("position", (9.0, 0.0))  # leaves the group
    net.run_for(0.5)
    assert Recorder.log == [("n2", "n0#1", OutReason.LEFT_GROUP)]
    n0.stop_interaction(session)
    net.run_for(0.5)
    assert Recorder.log[1:] == [("n1", "n0#1", OutReason.STOPPED)]


def test_a_crashed_initiator_leaves_its_participants_unreachable() -> None:
    net = line(2)
    net.node("n0").start_interaction(Initiator(), groups.within(2.5), "recorder")
    net.run_for(0.5)
    net.remove_node("n0")
    net.run_for(10.0)  # the defaults detect the crash within seconds
    assert Recorder.log == [("n1", "n0#1", OutReason.UNREACHABLE)]


def test_a_node_that_leaves_ends_its_roles_as_node_left() -> None:
    net = line(2)
    net.node("n0").start_interaction(Initiator(), groups.within(2.5), "recorder")
    net.run_for(0.5)
    net.leave("n1")
    assert Recorder.log == [("n1", "n0#1", OutReason.NODE_LEFT)]


class Releaser(Initiator):
    def __init__(self) -> None:
        self.joined: list[str] = []
        self.left: list[str] = []

    def in_group(self, participant: ParticipantRef) -> None:
        self.joined.append(participant.node_id)

    def out_group(self, participant: ParticipantRef) -> None:
        self.left.append(participant.node_id)


def test_an_initiator_releases_one_participant_and_keeps_the_others() -> None:
    net = line(4)
    n0 = net.node("n0")
    role = Releaser()
    n0.start_interaction(role, groups.within(3.5), "recorder")
    net.run_for(0.5)
    n2 = ParticipantRef("n2", "n0#1")
    assert role.release(n2)
    assert not role.release(n2)  # no member any more: nothing done
    net.run_for(2.0)
    assert [m.node_id for m in role.members] == ["n1", "n3"]
    assert Recorder.log == [("n2", "n0#1", OutReason.RELEASED)]
    assert role.left == []  # it asked: no out_group
    assert net.node("n2").participations() == []
    n0.update_node_property("position", (0.5, 0.0))  # n2 still matches: not asked again
    net.run_for(2.0)
    assert role.joined == ["n1", "n2", "n3"]
    # Once it has left the group and comes back, it is asked afresh.
    net.node("n2").update_node_property("position", (20.0, 0.0))
    net.run_for(0.5)
    net.node("n2").update_node_property("position", (2.0, 0.0))
    net.run_for(0.5)
    assert role.joined == ["n1", "n2", "n3", "n2"]
    with pytest.raises(LocalProtocolError, match="not a participant"):
        role.release(ParticipantRef("n1", "n0#9"))


def test_members_iterate_in_node_id_order_and_compare_as_a_set() -> None:
    net = line(6)
    role = Initiator()
    net.node("n3").start_interaction(role, groups.within(10), "recorder")
    net.run_for(1.0)
    members = role.members
    assert isinstance(members, MemberSet)
    assert [m.node_id for m in members] == ["n0", "n1", "n2", "n4", "n5"]
    assert members == {ParticipantRef(f"n{i}", "n3#1") for i in (0, 1, 2, 4, 5)}
    assert ParticipantRef("n0", "n3#1") in members
    assert members - {ParticipantRef("n0", "n3#1")} == frozenset(list(members)[1:])


MEMBER_ORDER = textwrap.dedent(
    """
    from objectplaces import Initiator, Participant, groups
    from objectplaces.sim import SimulatedNetwork

    net = SimulatedNetwork(seed=1)
    for i in range(12):
        node = net.add_node(f"agv-{i}")
        node.update_node_property("position", (float(i), 0.0))
        node.set_participant_factory("p", Participant)
    role = Initiator()
    net.node("agv-0").start_interaction(role, groups.within(100), "p")
    net.run_for(1.0)
    print(",".join(m.node_id for m in role.members))
    """
)


def test_member_order_does_not_depend_on_the_hash_seed() -> None:
    outputs = {
        subprocess.run(
            [sys.executable, "-c", MEMBER_ORDER],
            env={"PYTHONHASHSEED": seed},
            capture_output=True,
            text=True,
            check=True,
            timeout=120,
        ).stdout
        for seed in ("1", "2", "3")
    }
    assert len(outputs) == 1


def test_the_network_and_its_nodes_share_one_call_later_contract() -> None:
    net = SimulatedNetwork(seed=1)
    node = net.add_node("a")
    ran: list[str] = []
    for owner in (net, node):
        kept = owner.call_later(1.0, lambda: ran.append("kept"))
        cancelled = owner.call_later(1.0, lambda: ran.append("cancelled"))
        assert isinstance(kept, TimerHandle)
        assert kept.deadline == net.now + 1.0
        cancelled.cancel()
        with pytest.raises(LocalProtocolError, match="delay must be >= 0"):
            owner.call_later(-1.0, lambda: None)
        with pytest.raises(LocalProtocolError, match="delay must be >= 0"):
            owner.call_later(float("nan"), lambda: None)
        net.run_for(2.0)
    assert ran == ["kept", "kept"]


def test_the_simulator_detects_a_crash_by_default_as_the_mesh_does() -> None:
    net = SimulatedNetwork(seed=1)
    a, b, c = (net.add_node(n) for n in "abc")
    for node, x in ((a, 0.0), (b, 1.0), (c, 2.0)):
        node.update_node_property("position", (x, 0.0))
        node.set_participant_factory("p", Participant)
    role = Initiator()
    a.start_interaction(role, groups.within(40), "p")
    net.run_for(1.0)
    net.remove_node("c")
    net.run_for(120.0)
    assert [m.node_id for m in role.members] == ["b"]
    # The old behaviour, by name: no republication, no failure detection.
    quiet = SimulatedNetwork(seed=1, property_interval=None)
    assert quiet.add_node("x").machine.config.effective_failure_timeout is None


def test_the_tuplespace_is_a_property_of_the_node_and_of_its_roles() -> None:
    net = line(2)
    n0, n1 = net.node("n0"), net.node("n1")
    assert isinstance(n0.space, TupleSpace)
    assert n0.space is not n1.space
    n1.space.out(("greeting", "hello"))
    role = Initiator()
    n0.start_interaction(role, groups.within(2), "recorder")
    net.run_for(0.5)
    assert role.space is n0.space
    with pytest.raises(AttributeError):
        n0.space = TupleSpace()  # type: ignore[misc]
