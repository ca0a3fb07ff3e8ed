"""Bugs the simulation suite found in the core, each as the smallest run that shows it.

Those still open are marked ``xfail(strict=True)``: they fail today, and the day the
core is fixed they pass and the marker must go (strict turns the unexpected pass into a
failure). Each names the seeds that found it; ``python -m tests.soak.runner --seed N``
replays one.
"""

from __future__ import annotations

from typing import Any

import msgpack
import pytest

from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef, groups
from objectplaces.sim import SimulatedNetwork

HOSTILE = "x-hostile"


class Greeter(Initiator):
    """Records its members and what it hears."""

    def __init__(self) -> None:
        self.heard: list[tuple[str, Any]] = []

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        self.heard.append((participant.node_id, message))


class Listener(Participant):
    """Records what its initiator sends and whether it is active."""

    def __init__(self) -> None:
        self.heard: list[Any] = []
        self.active = False

    def in_group_of(self, initiator: InitiatorRef) -> None:
        self.active = True

    def out_group_of(self, initiator: InitiatorRef) -> None:
        self.active = False

    def receive(self, message: Any) -> None:
        self.heard.append(message)


def _pair(
    seed: int,
    *,
    reach: float = 5.0,
    a_radius: float | None = None,
    b_radius: float | None = None,
    **network: Any,
) -> tuple[SimulatedNetwork, Greeter, list[Listener], str]:
    """Initiator ``a`` with participant ``b`` (within ``reach``, each listening over its
    radius) in one session, both settled; ``network``: the network's settings, over a
    0.5 s heartbeat and a 1.5 s failure timeout."""
    net = SimulatedNetwork(
        **{"property_interval": 0.5, "failure_timeout": 1.5, **network}, seed=seed
    )
    a = net.add_node("a", interest_radius=a_radius)
    b = net.add_node("b", interest_radius=b_radius)
    a.update_node_property("position", (0.0, 0.0))
    b.update_node_property("position", (1.0, 0.0))
    roles: list[Listener] = []

    def make() -> Listener:
        roles.append(Listener())
        return roles[-1]

    b.set_participant_factory("listener", make)
    greeter = Greeter()
    session = a.start_interaction(greeter, groups.within(reach), "listener")
    net.run_for(1.0)
    assert greeter.members == {ParticipantRef("b", session.session_id)}
    return net, greeter, roles, session.session_id


@pytest.mark.parametrize(
    "values",
    [{"position": [1e308, 0.0]}, {"position": [0.0, -1e308]}, {"hull_length": 1e308}],
)
def test_a_position_too_large_for_millimetres_is_refused_like_any_bad_value(
    values: dict[str, Any],
) -> None:
    # Found by soak seeds 5, 6, 69, 82: OverflowError out of the decoder; fixed in the core.
    net = SimulatedNetwork(seed=1)
    a = net.add_node("a")
    net.inject(HOSTILE, "a", bytes(msgpack.packb([1, 1, values])))
    net.inject(HOSTILE, "a", bytes(msgpack.packb([1, 2, {"team": "red"}])))
    net.run_for(1.0)
    assert net.stats().dropped.get("failed", 0) == 0
    assert a.view()[HOSTILE] == {"team": "red"}  # the bad frame refused whole, the next one kept


def test_a_participant_that_timed_out_its_initiator_does_not_stay_a_member() -> None:
    # Found by soak seeds 17, 52, 67 (and 285, 317, 332 pending for good): the participant
    # dropped its role and its tombstone acked and dropped every later frame, while the
    # initiator, which still heard it, kept it as a member and lost its sends. Fixed in
    # the core: a participant that ends its role on its own says so.
    net, greeter, roles, sid = _pair(seed=3)
    a, b = net.node("a"), net.node("b")
    net.set_link("a", "b", both_ways=False, loss=1.0)  # b hears nothing of a; a hears b
    net.run_for(3.0)
    assert not roles[-1].active  # b's failure detector dropped a's session
    net.set_link("a", "b", both_ways=False, loss=0.0)
    net.run_for(10.0)  # many property intervals and failure timeouts
    for member in sorted(greeter.members, key=str):
        greeter.send(member, "hello")
    net.run_for(5.0)
    members = {info.session_id: info.members for info in a.sessions()}[sid]
    playing = [p for p in b.participations() if p.session_id == sid]
    assert ("b" in members) == bool(playing)
    assert all(role.heard == ["hello"] for role in roles if role.active)


def test_a_stopped_session_leaves_no_role_where_the_initiator_timed_out_the_participant() -> None:
    net, greeter, roles, sid = _pair(seed=4)
    a, b = net.node("a"), net.node("b")
    net.set_link("b", "a", both_ways=False, loss=1.0)  # a hears nothing of b; b hears a
    net.run_for(3.0)
    assert greeter.members == frozenset()  # a's failure detector dropped b
    a.stop_interaction(sid)
    net.set_link("b", "a", both_ways=False, loss=0.0)
    net.run_for(60.0)  # beyond every retransmission, failure timeout and tombstone
    assert [p.session_id for p in b.participations()] == []
    assert not any(role.active for role in roles)


def test_a_lost_left_does_not_keep_a_gone_participant_a_member() -> None:
    # Found by soak seeds 27, 88, 225, 332, 503, 801, 1289, 1315, 1327, 1363, 1802, 1955,
    # 2021, 2126, 2297, 2301: LEFT went once, best effort, and again only when another
    # frame of that channel arrived; lost, with an idle initiator, it kept a gone member
    # (or a pending one) for good. Fixed in the core: LEFT is repeated until acked.
    net, _, roles, sid = _pair(seed=3)
    a, b = net.node("a"), net.node("b")
    start = net.now
    net.set_link("a", "b", both_ways=False, loss=1.0)  # b stops hearing a
    net.run_for(1.3)
    net.set_link("b", "a", both_ways=False, loss=1.0)  # a stops hearing b, briefly
    while roles[-1].active and net.now < start + 5.0:
        net.run_for(0.01)
    assert not roles[-1].active  # b took a for failed and said LEFT into the lossy link
    net.set_link("b", "a", both_ways=False, loss=0.0)  # well before a's failure timeout
    net.set_link("a", "b", both_ways=False, loss=0.0)
    net.run_for(20.0)  # the initiator has nothing to send
    members = {info.session_id: info.members for info in a.sessions()}[sid]
    playing = [p for p in b.participations() if p.session_id == sid]
    assert ("b" in members) == bool(playing)


def test_a_crashed_run_loses_what_it_had_in_flight() -> None:
    # Found by soak seeds 597, 1428, 1771: a crashed run's frames still arrived after it
    # restarted under the same id; a peer applied the old run's property update over the
    # new run's (its sequence number is higher), or activated a role for a session of
    # the old run. Fixed in the simulated network: frames carry their sender's run.
    net = SimulatedNetwork(seed=1, delay=0.05, property_interval=0.1)
    a, b = net.add_node("a"), net.add_node("b")
    b.update_node_property("position", (1.0, 1.0))
    net.run_for(5.0)  # about fifty publications: b's sequence numbers are high
    b.update_node_property("position", (2.0, 2.0))
    net.run_for(0.01)  # that update is on the wire, 0.05 s of delay
    net.remove_node("b")
    net.add_node("b").update_node_property("position", (3.0, 3.0))
    net.run_for(3.0)
    assert a.view()["b"]["position"] == (3.0, 3.0)


def test_frames_of_an_overtaken_epoch_do_not_open_a_role_later() -> None:
    # Found by soak seed 2200: a newer activation's ACTIVATE overtook an older epoch's
    # ACTIVATE and DEACTIVATE; the participant dropped those without an ack, so the
    # initiator retransmitted them until every tombstone had expired, and the old
    # ACTIVATE then opened a role no session knows. Fixed in the core: they are acked.
    net, _, roles, sid = _pair(seed=5)
    a, b = net.node("a"), net.node("b")
    net.set_link("a", "b", both_ways=False, delay=1.0)  # what a says next arrives late
    for x in (9.0, 1.0, 9.0):  # out, in (epoch 2), out again
        b.update_node_property("position", (x, 0.0))
        net.run_for(0.05)
    net.set_link("a", "b", both_ways=False, delay=0.005)
    b.update_node_property("position", (1.0, 0.0))  # in again: epoch 3 overtakes epoch 2
    net.run_for(3.0)
    a.stop_interaction(sid)
    net.run_for(2.0)
    # Epoch 2's frames were acked on arrival: nothing of the session is left to retransmit
    # (unacked, they would be until the channel broke, long after b's tombstones expire).
    assert set(a.machine.state_counts().values()) == {0}
    net.run_for(60.0)  # beyond every retransmission and tombstone
    assert b.participations() == []
    assert not any(role.active for role in roles)


def test_a_participant_out_of_scope_of_its_initiator_still_finds_its_crash() -> None:
    # Found by soak seed 1048 (with nodes at rest, whose longer timeout widened the
    # window): the participant moved so that its initiator left its scope, and the
    # view forgot when the initiator was last heard with its properties; the initiator
    # crashed, and the participant played its role for ever.
    net, _, roles, _ = _pair(seed=1, reach=1000.0, b_radius=10.0)
    b = net.node("b")
    b.update_node_property("position", (200.0, 0.0))  # a is out of b's scope now
    net.run_for(1.0)
    assert "a" not in b.view()
    assert roles[-1].active  # still a member: a hears b, and it lives
    net.remove_node("a")  # a crashes
    net.run_for(3.0)
    assert not roles[-1].active
    assert b.participations() == []


def test_an_out_of_scope_initiator_is_forgotten_quietly_once_its_roles_end() -> None:
    # The other side of seed 1048: when the initiator's session ends normally, the
    # liveness kept for its roles must go with them. Kept, the participant, which no
    # longer hears the initiator, counted it failed at its timeout: a departure with
    # no properties of a node that lives.
    net, _, roles, sid = _pair(seed=1, reach=1000.0, a_radius=1000.0, b_radius=10.0)
    a, b = net.node("a"), net.node("b")
    departures: list[tuple[str, dict[str, Any]]] = []
    b.register_node_departure_observer(lambda node, last: departures.append((node, dict(last))))
    b.update_node_property("position", (200.0, 0.0))  # a hears b, b no longer hears a
    net.run_for(1.0)
    assert "a" not in b.view()
    assert roles[-1].active
    a.stop_interaction(sid)
    net.run_for(10.0)  # many failure timeouts
    assert not roles[-1].active
    assert b.participations() == []
    assert departures == []
    assert b.stats().counters.get("departed_failed", 0) == 0
    # Back in scope, a is heard as any node, and its crash is a departure again.
    b.update_node_property("position", (1.0, 0.0))
    net.run_for(2.0)
    assert "a" in b.view()
    net.remove_node("a")
    net.run_for(3.0)
    assert [node for node, _ in departures] == ["a"]


def test_a_node_that_declined_and_took_its_initiator_for_failed_tells_it() -> None:
    # Found by soak seed 1259 (with nodes at rest): the DECLINED of a node without the
    # role was lost, a partition made the node take the initiator for failed and end
    # the channel, and the initiator's ACTIVATE, retransmitted after the heal, was only
    # acknowledged: the initiator held the node pending for ever. The node now tells
    # it LEFT, as a member would, and the initiator asks it again.
    net = SimulatedNetwork(seed=1, property_interval=0.5, failure_timeout=1.5)
    a = net.add_node("a", failure_timeout=10.0)  # a waits longer than b
    b = net.add_node("b")  # b plays no role
    a.update_node_property("position", (0.0, 0.0))
    b.update_node_property("position", (1.0, 0.0))
    net.run_for(1.0)
    session = a.start_interaction(Greeter(), groups.within(5.0), "listener")
    net.run_for(0.003)  # the ACTIVATE is on its way; the DECLINED will go into the cut
    net.partition(["a"], ["b"])
    net.run_for(3.0)  # b takes a for failed, a still holds b
    [info] = a.sessions()
    assert info.pending == frozenset({"b"})
    net.heal()
    net.run_for(10.0)
    [info] = a.sessions()
    assert info.session_id == session.session_id
    assert info.pending == frozenset()
    assert info.members == frozenset()


def test_a_member_whose_move_out_of_scope_was_lost_leaves_once_only_its_channel_is_heard() -> None:
    # Found by soak seed 2754: a member moved out of its scoped initiator's cells, and
    # the one publication that said so was lost. Its beats and republications went to
    # its new cells only, while the session's frames (acks) kept it alive at the
    # initiator: a member for ever, at a place it had left. Fixed in the core: a node
    # heard by its channels alone for a failure timeout is asked for a snapshot.
    net, greeter, roles, _ = _pair(seed=1, reach=5.0, a_radius=10.0, b_radius=10.0)
    a, b = net.node("a"), net.node("b")
    net.set_link("b", "a", both_ways=False, loss=1.0)
    b.update_node_property("position", (200.0, 0.0))  # out of a's cells; a misses it
    net.run_for(0.05)
    net.set_link("b", "a", both_ways=False, loss=0.0)
    for _ in range(20):  # ten seconds of a session that talks: b's acks come back
        for member in sorted(greeter.members, key=str):
            greeter.send(member, "ping")
        net.run_for(0.5)
    assert greeter.members == frozenset()
    assert not roles[-1].active
    assert "b" not in a.view()


def test_a_member_that_ended_its_role_unheard_is_asked_again_once_its_channel_breaks() -> None:
    # Found by soak seed 9935: a partition outlasted the participant's failure timeout
    # for its initiator, but not the initiator's for the participant, which was at rest
    # (a longer wait). The participant ended its role, its LEFT went into the partition
    # until its tombstone expired, and it dropped the initiator's frames after the heal
    # as those of a session it never had. The channel broke, the member was removed, and
    # nothing asked it again: at rest, it published nothing that would. Fixed in the
    # core: a broken channel whose node was heard meanwhile asks it afresh, as a LEFT does.
    net, greeter, roles, sid = _pair(
        seed=1, property_interval=60.0, beat_interval=0.5, rest_beat_interval=10.0
    )
    b = net.node("b")
    b.set_at_rest(True)
    net.run_for(5.0)  # b's rest announced: a waits 30 s for it, b waits 2 s for a
    assert roles[-1].active
    net.partition(["a"], ["b"])
    for member in sorted(greeter.members, key=str):
        greeter.send(member, "into the cut")
    net.run_for(15.0)  # b ended its role, and its tombstone expired; a still holds b
    assert not roles[-1].active
    assert "b" in {m.node_id for m in greeter.members}
    net.heal()
    net.run_for(60.0)
    assert greeter.members == {ParticipantRef("b", sid)}
    assert roles[-1].active


@pytest.mark.parametrize("cut", [5.0, 20.0])
def test_a_member_that_ended_its_role_unheard_is_asked_again_by_an_idle_initiator(
    cut: float,
) -> None:
    # Found by soak seed 2999 (without republication): as in seed 9935, but the
    # initiator had nothing to send, so no channel broke. The participant's LEFT was lost
    # until its tombstone expired (after the heal: 5 s, each repeat lost; or during it:
    # 20 s), and the initiator held a member that played no role, for good. Fixed in the
    # core: an initiator probes its idle members, and a node that no longer knows the
    # channel answers with LEFT.
    net, greeter, roles, sid = _pair(
        seed=1, property_interval=None, beat_interval=0.5, rest_beat_interval=10.0
    )
    b = net.node("b")
    b.set_at_rest(True)
    net.run_for(5.0)  # b's rest announced: a waits 30 s for it, b waits 1.5 s for a
    net.partition(["a"], ["b"])
    net.run_for(cut)  # b ended its role; a still holds b
    assert not roles[-1].active
    assert "b" in {m.node_id for m in greeter.members}
    if cut < net.node("b").machine.config.tombstone_ttl:
        net.set_link("b", "a", loss=1.0, both_ways=False)  # every repeat of b's LEFT is lost
        net.heal()
        net.run_for(net.node("b").machine.config.tombstone_ttl)
        net.set_link("b", "a", loss=0.0, both_ways=False)
    else:
        net.heal()
    net.run_for(60.0)
    assert greeter.members == {ParticipantRef("b", sid)}
    assert roles[-1].active


def test_a_member_that_plays_its_role_takes_the_probes_unnoticed() -> None:
    net, greeter, roles, sid = _pair(seed=1, property_interval=None, beat_interval=0.5)
    a = net.node("a")
    ttl = a.machine.config.tombstone_ttl
    before = a.machine.sent_by_kind.get("channel", [0, 0])[0]
    net.run_for(ttl - 2.0)  # the session is younger than the probes' interval
    assert a.machine.sent_by_kind.get("channel", [0, 0])[0] == before
    net.run_for(3 * ttl)
    assert a.machine.sent_by_kind["channel"][0] >= before + 3  # a probe each interval
    assert greeter.members == {ParticipantRef("b", sid)}
    assert len(roles) == 1
    assert roles[0].active
    assert roles[0].heard == []
    assert greeter.heard == []
