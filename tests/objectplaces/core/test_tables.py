"""SessionTable and ParticipationTable alone, with frames built by hand."""

from __future__ import annotations

from typing import Any

import pytest

from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef, groups
from objectplaces.core import codec
from objectplaces.core.bindings import DriverLink, InitiatorContext, ParticipantContext
from objectplaces.core.channel import retransmission_span
from objectplaces.core.config import NodeConfig
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.events import Callback, Send, TimerHandle
from objectplaces.core.messages import ChannelAck, ChannelData, FrameKind, PropertyUpdate
from objectplaces.core.observers import Observers
from objectplaces.core.outbox import Outbox
from objectplaces.core.participations import ParticipationTable
from objectplaces.core.plumbing import Plumbing
from objectplaces.core.sessions import SessionTable
from objectplaces.core.timers import (
    ExpireTombstone,
    ParticipationOwner,
    RepeatLeft,
    RoleOwner,
)
from objectplaces.core.view import PropertyView


def sent(outbox: Outbox) -> list[tuple[str, Any]]:
    """(target, decoded frame) of every frame queued, then clears the outbox."""
    out = []
    for output in outbox.take_outputs():
        assert isinstance(output, Send)
        out.append((output.target, codec.decode(output.data)))
    return out


def called(outbox: Outbox) -> list[tuple[str, tuple[Any, ...]]]:
    """(callback name, args) of every callback queued, then clears them."""
    return [(getattr(c.fn, "__name__", "?"), c.args) for c in outbox.take_callbacks()]


class Role(Initiator):
    pass


class Host:
    """The machine's share of a role context: identity, clock and timers."""

    def __init__(self, plumbing: Plumbing) -> None:
        self.node_id = plumbing.node_id
        self.space = None
        self.now = 0.0
        self.driver = DriverLink(lambda: self.now)
        self.role_timers = plumbing.role_timers

    def call_later(
        self, delay: float, fn: Any, now: float, *, owner: RoleOwner | None = None
    ) -> TimerHandle:
        return self.role_timers.schedule(now, delay, fn, owner)


# ---------------------------------------------------------------------- initiator side


class InitiatorSide:
    def __init__(self) -> None:
        self.plumbing = Plumbing.build("a", NodeConfig(cell_size=10.0))
        self.outbox, self.timers = self.plumbing.outbox, self.plumbing.timers
        self.view = PropertyView(self.plumbing, observers=Observers(self.outbox))
        self.own = {"position": (0.0, 0.0)}
        self.host = Host(self.plumbing)
        self.table = SessionTable(
            self.plumbing,
            view=self.view,
            own=self.own,
            binder=lambda sid: InitiatorContext(self.host, self.table, sid),
        )

    def place(self, node: str, seq: int, x: float) -> None:
        self.view.apply(node, PropertyUpdate(seq, {"position": (x, 0.0)}, full=True), now=0.0)
        self.table.node_changed(node, now=0.0)

    def answer(self, node: str, seq: int, kind: FrameKind, epoch: int = 1) -> None:
        self.table.on_frame(node, ChannelData(False, 1, epoch, seq, kind, None), now=0.0)


@pytest.fixture
def side() -> InitiatorSide:
    s = InitiatorSide()
    s.view.apply("b", PropertyUpdate(1, {"position": (1.0, 0.0)}, full=True), now=0.0)
    s.view.apply("c", PropertyUpdate(1, {"position": (50.0, 0.0)}, full=True), now=0.0)
    return s


def test_open_activates_only_matching_nodes(side: InitiatorSide) -> None:
    role = Role()
    sid = side.table.open(role, groups.within(5.0), "voter", now=0.0)
    assert sid == "a#1"
    assert called(side.outbox) == [("started", ())]
    assert sent(side.outbox) == [
        ("b", ChannelData(True, 1, 1, 0, FrameKind.ACTIVATE, ["voter", "Role"]))
    ]
    assert side.table.infos()[0].pending == frozenset({"b"})


def test_activated_makes_a_member_and_declined_is_never_told(side: InitiatorSide) -> None:
    side.place("c", 2, 2.0)
    role = Role()
    side.table.open(role, groups.within(5.0), "voter", now=0.0)
    called(side.outbox), sent(side.outbox)
    side.answer("b", 0, FrameKind.ACTIVATED)
    side.answer("c", 0, FrameKind.DECLINED)
    assert called(side.outbox) == [("in_group", (ParticipantRef("b", "a#1"),))]
    assert sent(side.outbox) == [
        ("b", ChannelAck(True, 1, 1, 0)),
        ("c", ChannelAck(True, 1, 1, 0)),
    ]
    side.place("c", 3, 2.5)  # still matching: not asked again
    assert sent(side.outbox) == []
    assert side.table.members_of("a#1") == frozenset({ParticipantRef("b", "a#1")})


def test_a_member_that_stops_matching_is_deactivated_and_its_late_frames_dropped(
    side: InitiatorSide,
) -> None:
    role = Role()
    side.table.open(role, groups.within(5.0), "voter", now=0.0)
    side.answer("b", 0, FrameKind.ACTIVATED)
    called(side.outbox), sent(side.outbox)
    side.place("b", 2, 30.0)
    assert called(side.outbox) == [("out_group", (ParticipantRef("b", "a#1"),))]
    assert sent(side.outbox) == [
        ("b", ChannelData(True, 1, 1, 1, FrameKind.DEACTIVATE, "left_group"))
    ]
    assert side.table.counts() == {"sessions": 1, "members": 0, "closing_channels": 1}
    side.table.on_frame("b", ChannelData(False, 1, 1, 1, FrameKind.ROLE, "vote"), now=0.0)
    assert called(side.outbox) == []  # guarantee 1: never delivered
    assert sent(side.outbox) == [("b", ChannelAck(True, 1, 1, 1))]  # but acked
    assert side.outbox.counters["dropped_non_member"] == 1
    side.table.on_ack("b", ChannelAck(False, 1, 1, 1), now=0.0)
    assert side.table.counts()["closing_channels"] == 0


def test_send_refuses_non_members_and_foreign_participants(side: InitiatorSide) -> None:
    side.table.open(Role(), groups.within(5.0), "voter", now=0.0)
    sent(side.outbox)
    pending = ParticipantRef("b", "a#1")
    assert not side.table.send("a#1", pending, "early", now=0.0)  # not joined yet
    with pytest.raises(LocalProtocolError, match="is not a participant of 'a#1'"):
        side.table.send("a#1", ParticipantRef("b", "a#2"), "x", now=0.0)
    with pytest.raises(LocalProtocolError, match="not serialisable"):
        side.table.send("a#1", pending, object(), now=0.0)
    assert sent(side.outbox) == []


def test_stop_deactivates_everyone_and_the_session_goes_once_acked(side: InitiatorSide) -> None:
    role = Role()
    side.table.open(role, groups.within(5.0), "voter", now=0.0)
    side.answer("b", 0, FrameKind.ACTIVATED)
    called(side.outbox), sent(side.outbox)
    side.table.stop("a#1", now=1.0)
    assert called(side.outbox) == []  # the role asked for it: no out_group
    assert [frame.kind for _, frame in sent(side.outbox)] == [FrameKind.DEACTIVATE]
    assert side.table.infos() == []
    assert side.table.role_of("a#1") is None
    with pytest.raises(LocalProtocolError, match="unknown session 'a#1'"):
        side.table.stop("a#1", now=1.0)
    side.table.on_ack("b", ChannelAck(False, 1, 1, 1), now=0.0)
    assert side.table.counts() == {"sessions": 0, "members": 0, "closing_channels": 0}


def test_a_peer_that_left_leaves_at_once_without_deactivation(side: InitiatorSide) -> None:
    side.table.open(Role(), groups.within(5.0), "voter", now=0.0)
    side.answer("b", 0, FrameKind.ACTIVATED)
    called(side.outbox), sent(side.outbox)
    side.table.peer_gone("b", failed_at=None)
    assert called(side.outbox) == [("out_group", (ParticipantRef("b", "a#1"),))]
    assert sent(side.outbox) == []
    assert side.table.counts()["closing_channels"] == 0


def test_a_peer_taken_for_failed_is_deactivated_all_the_same(side: InitiatorSide) -> None:
    side.table.open(Role(), groups.within(5.0), "voter", now=0.0)
    side.answer("b", 0, FrameKind.ACTIVATED)
    called(side.outbox), sent(side.outbox)
    side.table.peer_gone("b", failed_at=2.0)  # it may only be cut off one way
    assert called(side.outbox) == [("out_group", (ParticipantRef("b", "a#1"),))]
    assert sent(side.outbox) == [
        ("b", ChannelData(True, 1, 1, 1, FrameKind.DEACTIVATE, "unreachable"))
    ]
    assert side.table.counts()["closing_channels"] == 1  # retransmitted until acked
    side.table.on_ack("b", ChannelAck(False, 1, 1, 1), now=2.5)
    assert side.table.counts()["closing_channels"] == 0


def test_a_participant_that_left_on_its_own_is_dropped_and_asked_again(
    side: InitiatorSide,
) -> None:
    side.table.open(Role(), groups.within(5.0), "voter", now=0.0)
    side.answer("b", 0, FrameKind.ACTIVATED)
    called(side.outbox), sent(side.outbox)
    side.answer("b", 1, FrameKind.LEFT)  # out of band: numbered past b's stream
    assert called(side.outbox) == [("out_group", (ParticipantRef("b", "a#1"),))]
    assert sent(side.outbox) == [  # b still matches: a fresh activation, a new epoch
        ("b", ChannelData(True, 1, 2, 0, FrameKind.ACTIVATE, ["voter", "Role"])),
        ("b", ChannelAck(True, 1, 1, 1)),  # and the LEFT acked with its own number
    ]
    side.answer("b", 1, FrameKind.LEFT)  # a repeat, of the old epoch: acked, nothing more
    assert called(side.outbox) == []
    assert sent(side.outbox) == [("b", ChannelAck(True, 1, 1, 1))]


def test_a_rejoining_node_gets_a_new_epoch(side: InitiatorSide) -> None:
    side.table.open(Role(), groups.within(5.0), "voter", now=0.0)
    side.answer("b", 0, FrameKind.ACTIVATED)
    side.place("b", 2, 30.0)
    side.place("b", 3, 2.0)
    frames = [f for _, f in sent(side.outbox) if isinstance(f, ChannelData)]
    assert [(f.epoch, f.seq, f.kind) for f in frames] == [
        (1, 0, FrameKind.ACTIVATE),
        (1, 1, FrameKind.DEACTIVATE),
        (2, 0, FrameKind.ACTIVATE),
    ]


@pytest.mark.source_only("arguments of the wrong type")
def test_bad_session_arguments_are_refused(side: InitiatorSide) -> None:
    with pytest.raises(LocalProtocolError, match="must subclass Initiator"):
        side.table.open(object(), groups.within(1), "v", now=0.0)  # type: ignore[arg-type]
    with pytest.raises(LocalProtocolError, match="must be callable"):
        side.table.open(Role(), 3, "v", now=0.0)  # type: ignore[arg-type]
    with pytest.raises(LocalProtocolError, match="non-empty string"):
        side.table.open(Role(), groups.within(1), "", now=0.0)


# ---------------------------------------------------------------------- participant side


class Voter(Participant):
    def in_group_of(self, initiator: InitiatorRef) -> None:
        pass

    def out_group_of(self, initiator: InitiatorRef) -> None:
        pass


LIFE = retransmission_span(0.2, 12)
"""How long the tables' tombstones live: as long as a channel retransmits (28.6 s)."""


class ParticipantSide:
    def __init__(self) -> None:
        self.plumbing = Plumbing.build("b", NodeConfig(tombstone_ttl=5.0))
        self.outbox, self.timers = self.plumbing.outbox, self.plumbing.timers
        self.host = Host(self.plumbing)
        self.table = ParticipationTable(
            self.plumbing,
            binder=lambda owner, ref: ParticipantContext(self.host, self.table, owner, ref),
        )

    def frame(self, seq: int, kind: FrameKind, payload: Any = None, epoch: int = 1) -> None:
        data = ChannelData(True, 1, epoch, seq, kind, payload)
        self.table.on_frame("a", data, now=1.0)


@pytest.fixture
def part() -> ParticipantSide:
    return ParticipantSide()


def test_activate_with_a_factory_activates_the_role(part: ParticipantSide) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    assert sent(part.outbox) == [
        ("a", ChannelAck(False, 1, 1, 0)),
        ("a", ChannelData(False, 1, 1, 0, FrameKind.ACTIVATED, None)),
    ]
    [(name, args)] = called(part.outbox)
    assert (name, args) == ("in_group_of", (InitiatorRef("a", "a#1"),))
    [info] = part.table.infos()
    assert (info.session_id, info.initiator, info.participant_role) == ("a#1", "a", "voter")


@pytest.mark.parametrize("factory", [None, lambda: 1 / 0, lambda: "not a role"])
def test_no_usable_factory_declines_and_ends_once_acked(
    part: ParticipantSide, factory: Any
) -> None:
    if factory is not None:
        part.table.set_factory("voter", factory)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    assert sent(part.outbox)[-1] == ("a", ChannelData(False, 1, 1, 0, FrameKind.DECLINED, None))
    assert called(part.outbox) == []
    assert part.table.counts()["participations"] == 1  # until the DECLINED is acked
    part.table.on_ack("a", ChannelAck(True, 1, 1, 0), now=1.0)
    assert part.table.counts() == {"participations": 0, "tombstones": 1}


def test_deactivate_ends_the_role_and_a_tombstone_drops_late_frames(part: ParticipantSide) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    part.frame(1, FrameKind.DEACTIVATE)
    assert [n for n, _ in called(part.outbox)] == ["in_group_of", "out_group_of"]
    sent(part.outbox)
    part.frame(1, FrameKind.DEACTIVATE)  # a retransmission: our ack was lost
    assert sent(part.outbox) == [("a", ChannelAck(False, 1, 1, 1))]
    assert called(part.outbox) == []
    assert part.outbox.counters["dropped_stale"] == 1
    expires = 1.0 + LIFE  # the closed channel's timer is dead
    assert part.timers.next_deadline() == expires
    assert part.timers.pop_due(expires) == ExpireTombstone("a", 1)
    part.table.expire_tombstone("a", 1, now=expires)
    assert part.table.counts() == {"participations": 0, "tombstones": 0}


def test_a_tombstone_outlives_every_retransmission_of_an_older_epoch(
    part: ParticipantSide,
) -> None:
    # Soak seed 1932: epoch 4's ACTIVATE and DEACTIVATE went unacknowledged (loss), epoch
    # 5 came and went, and epoch 4's ACTIVATE, retransmitted until its channel broke,
    # arrived after epoch 5's tombstone (10 s) expired: it opened a role no session knew.
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"], epoch=5)
    part.frame(1, FrameKind.DEACTIVATE, epoch=5)
    called(part.outbox), sent(part.outbox)
    assert part.plumbing.config.tombstone_ttl < LIFE
    assert part.timers.next_deadline() == 1.0 + LIFE
    late = 1.0 + LIFE - 0.01  # epoch 4's last retransmission, sent before epoch 5 opened
    part.table.on_frame("a", ChannelData(True, 1, 4, 0, FrameKind.ACTIVATE, ["voter", "R"]), late)
    assert sent(part.outbox) == [("a", ChannelAck(False, 1, 4, 0))]
    assert called(part.outbox) == []
    assert part.table.counts() == {"participations": 0, "tombstones": 1}


def test_a_newer_epoch_supersedes_the_old_participation(part: ParticipantSide) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"], epoch=2)
    assert [n for n, _ in called(part.outbox)] == ["in_group_of", "out_group_of", "in_group_of"]
    part.frame(5, FrameKind.ROLE, "old", epoch=1)  # the old channel: stale
    assert part.outbox.counters["dropped_stale"] == 1


def test_frames_of_an_epoch_overtaken_by_a_newer_one_are_acked_and_dropped(
    part: ParticipantSide,
) -> None:
    # Soak seed 2200: epoch 3's ACTIVATE overtook epoch 2's ACTIVATE and DEACTIVATE; left
    # unacked, those were retransmitted until the tombstones were gone, then opened a role.
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"], epoch=3)
    called(part.outbox), sent(part.outbox)
    part.frame(1, FrameKind.DEACTIVATE, epoch=2)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"], epoch=2)
    assert sent(part.outbox) == [
        ("a", ChannelAck(False, 1, 2, 1)),
        ("a", ChannelAck(False, 1, 2, 0)),
    ]
    assert called(part.outbox) == []
    assert part.outbox.counters["dropped_stale"] == 2


def test_only_an_activation_opens_a_participation(part: ParticipantSide) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(1, FrameKind.ROLE, "request")  # overtook its ACTIVATE, or a forgery
    assert called(part.outbox) == []
    assert sent(part.outbox) == []  # not even acked: the initiator will retransmit
    assert part.table.counts() == {"participations": 0, "tombstones": 0}
    assert part.outbox.counters["dropped_unknown_session"] == 1
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    part.frame(1, FrameKind.ROLE, "request")  # the retransmission
    assert [(n, a) for n, a in called(part.outbox)] == [
        ("in_group_of", (InitiatorRef("a", "a#1"),)),
        ("receive", ("request",)),
    ]


def test_send_from_an_ended_role_is_refused(part: ParticipantSide) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    owner = ParticipationOwner("a", 1, 1)
    assert part.table.send(owner, "vote", now=1.0)
    assert not part.table.send(ParticipationOwner("a", 1, 2), "vote", now=1.0)  # other epoch
    part.frame(1, FrameKind.DEACTIVATE)
    assert not part.table.send(owner, "vote", now=1.0)
    with pytest.raises(LocalProtocolError, match="not serialisable"):
        part.table.send(owner, {"x": object()}, now=1.0)


def test_factories_are_checked(part: ParticipantSide) -> None:
    with pytest.raises(LocalProtocolError, match="non-empty string"):
        part.table.set_factory("", Voter)
    with pytest.raises(LocalProtocolError, match="not callable"):
        part.table.set_factory("voter", 42)  # type: ignore[arg-type]
    part.table.set_factory("voter", Voter)
    part.table.set_factory("voter", None)
    assert dict(part.table.factories) == {}


def test_callbacks_carry_their_session_for_the_log(part: ParticipantSide) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    [callback] = part.outbox.take_callbacks()
    assert isinstance(callback, Callback)
    assert callback.session_id == "a#1"


def test_role_timers_die_with_their_session(side: InitiatorSide) -> None:
    role = Role()
    side.table.open(role, groups.within(5.0), "voter", now=0.0)
    handle = role.call_later(1.0, lambda: None)
    assert role.node_id == "a"
    assert role.session_id == "a#1"
    side.table.stop("a#1", now=0.5)
    assert handle.cancelled


def test_role_timers_die_with_their_participation(part: ParticipantSide) -> None:
    roles: list[Voter] = []

    def factory() -> Voter:
        roles.append(Voter())
        return roles[-1]

    part.table.set_factory("voter", factory)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    [role] = roles
    handle = role.call_later(1.0, lambda: None)
    assert role.initiator == InitiatorRef("a", "a#1")
    part.frame(1, FrameKind.DEACTIVATE)
    assert handle.cancelled


def test_a_role_ended_on_our_own_is_reported_left_instead_of_acked(
    part: ParticipantSide,
) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    called(part.outbox), sent(part.outbox)
    part.table.initiator_gone("a", now=2.0, failed=True)  # we took it for failed
    left = ("a", ChannelData(False, 1, 1, 1, FrameKind.LEFT, None))  # past our stream
    assert sent(part.outbox) == [left]
    assert [n for n, _ in called(part.outbox)] == ["out_group_of"]
    part.frame(1, FrameKind.ROLE, "are you there?")  # it lives, and still talks to us
    assert sent(part.outbox) == [left]  # told again, never acked into the void
    assert called(part.outbox) == []


def repeat_lefts_due(part: ParticipantSide, now: float) -> None:
    while (action := part.timers.pop_due(now)) is not None:
        if isinstance(action, RepeatLeft):
            part.table.repeat_left(action, now)


def test_a_left_is_repeated_with_backoff_until_acked_with_its_own_number(
    part: ParticipantSide,
) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    sent(part.outbox)
    part.table.initiator_gone("a", now=2.0, failed=True)
    left = ("a", ChannelData(False, 1, 1, 1, FrameKind.LEFT, None))
    assert sent(part.outbox) == [left]
    repeat_lefts_due(part, now=2.25)  # retransmit_timeout 0.2
    assert sent(part.outbox) == [left]
    repeat_lefts_due(part, now=2.5)  # backed off: the next one is due at 2.6
    assert sent(part.outbox) == []
    repeat_lefts_due(part, now=2.65)
    assert sent(part.outbox) == [left]
    assert not part.table.on_ack("a", ChannelAck(True, 1, 1, 0), now=2.7)  # a late stream ack
    repeat_lefts_due(part, now=3.5)
    assert sent(part.outbox) == [left]  # is not taken for the LEFT's
    assert part.table.on_ack("a", ChannelAck(True, 1, 1, 1), now=3.6)
    repeat_lefts_due(part, now=4.9)
    assert sent(part.outbox) == []  # acked: no more


def test_a_left_superseded_by_a_later_channel_s_is_not_repeated(part: ParticipantSide) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    part.table.initiator_gone("a", now=2.0, failed=True)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"], epoch=2)  # activated afresh
    part.table.initiator_gone("a", now=2.0, failed=True)  # and ended on our own again
    sent(part.outbox)
    repeat_lefts_due(part, now=2.25)  # both channels' timers are due: one LEFT only
    assert sent(part.outbox) == [("a", ChannelData(False, 1, 2, 1, FrameKind.LEFT, None))]


def test_a_left_is_not_repeated_to_an_initiator_that_left(part: ParticipantSide) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    part.table.initiator_gone("a", now=2.0, failed=True)
    sent(part.outbox)
    part.table.initiator_gone("a", now=2.1, failed=False)  # then its Leave arrived
    repeat_lefts_due(part, now=4.9)
    assert sent(part.outbox) == []


def test_a_role_whose_initiator_left_is_not_reported(part: ParticipantSide) -> None:
    part.table.set_factory("voter", Voter)
    part.frame(0, FrameKind.ACTIVATE, ["voter", "Requester"])
    sent(part.outbox)
    part.table.initiator_gone("a", now=2.0, failed=False)
    assert sent(part.outbox) == []
    part.frame(1, FrameKind.ROLE, "late")
    assert sent(part.outbox) == [("a", ChannelAck(False, 1, 1, 1))]


def test_a_frame_ahead_of_frame_0_draws_no_ack() -> None:
    # Nothing is delivered in order yet: an ack of -1 would tell the sender nothing, and
    # the sender's intake refuses negative acks as malformed, counting an honest peer.
    plumbing = Plumbing.build("b", NodeConfig())
    channel = plumbing.channels.open(to_participant=False, session=7, epoch=0)
    early = ChannelData(True, 7, 0, 1, FrameKind.ROLE, "late")
    delivered, ack = channel.on_data(early)
    plumbing.channels.acknowledge("a", ack)
    assert delivered == []
    assert sent(plumbing.outbox) == []
    first = ChannelData(True, 7, 0, 0, FrameKind.ROLE, "first")
    delivered, ack = channel.on_data(first)
    plumbing.channels.acknowledge("a", ack)
    assert [d.seq for d in delivered] == [0, 1]
    assert [frame for _, frame in sent(plumbing.outbox)] == [ChannelAck(False, 7, 0, 1)]
