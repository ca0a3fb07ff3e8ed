"""The initiator side: the sessions this node started, and their members (§3).

The table decides; the state of each session, and why each part of it is kept, is in
session_state.py. Membership follows the view: whenever a candidate's properties or the
initiator's own change, the definition is evaluated again (``node_changed``,
``reevaluate_all``), and the differences become ``ACTIVATE`` and ``DEACTIVATE``
frames. A stopped session is forgotten once every member's deactivation is
acknowledged or its channel broke (guarantee 4: nothing left behind).

Failure detection is local and links can fail one way, so the two sides can disagree
about a membership: the table resolves it toward "not a member", the state a message
can never be lost in (``peer_gone``, ``_on_left``, ``probe``).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping
from typing import Any

from objectplaces.core import codec
from objectplaces.core.channel import Channel
from objectplaces.core.config import SessionInfo
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.groups import DefinitionLike, checked_definition
from objectplaces.core.ids import ParticipantRef, SessionId, session_id_for, session_number
from objectplaces.core.members import MemberSet
from objectplaces.core.messages import ChannelAck, ChannelData, FrameKind
from objectplaces.core.plumbing import Plumbing
from objectplaces.core.roles import Initiator, InitiatorBinding, OutReason, bind, is_bound
from objectplaces.core.session_state import MemberState, SessionState, session_counts
from objectplaces.core.timers import SessionOwner
from objectplaces.core.view import PropertyView

__all__ = ["SessionTable"]


class SessionTable:
    """Every session this node initiated, from start until nothing of it is left.

    Args:
        plumbing: the node's id (session ids are ``<node>#<number>``), outbox, channels
            and role timers (an initiator role's timers die with its session).
        view: the property view that definitions are resolved over.
        own: this node's own properties (the definition's first argument).
        binder: makes the context each initiator role is bound to.
    """

    def __init__(
        self,
        plumbing: Plumbing,
        *,
        view: PropertyView,
        own: Mapping[str, Any],
        binder: Callable[[SessionId], InitiatorBinding],
    ) -> None:
        self._node_id = plumbing.node_id
        self._outbox = plumbing.outbox
        self._channels = plumbing.channels
        self._role_timers = plumbing.role_timers
        self._view = view
        self._own = own
        self._binder = binder
        self._sessions: dict[int, SessionState] = {}
        self._numbers = itertools.count(1)

    # ------------------------------------------------------------------ commands

    def open(
        self, role: Initiator, definition: DefinitionLike, participant_role: str, now: float
    ) -> SessionId:
        """Start a session: the role hears ``started``, then matches are activated.

        Raises:
            LocalProtocolError: a bad argument, ``role`` already plays in a session, or
                the definition cannot resolve a group; nothing is left behind then.
        """
        if not isinstance(role, Initiator):
            raise LocalProtocolError(f"initiator role must subclass Initiator, got {role!r}")
        if is_bound(role):
            raise LocalProtocolError(f"{role!r} already plays in session {role.session_id!r}")
        definition = checked_definition(definition, self._own)
        if not isinstance(participant_role, str) or not participant_role:
            raise LocalProtocolError(
                f"participant role name must be a non-empty string, got {participant_role!r}"
            )
        number = next(self._numbers)
        sid = session_id_for(self._node_id, number)
        session = SessionState(number, sid, role, definition, participant_role, now)
        self._sessions[number] = session
        bind(role, self._binder(sid))  # before any callback of the session runs
        self._outbox.call(role.started, (), sid)
        self._reevaluate(session, now)
        return sid

    def stop(self, sid: str, now: float) -> None:
        """Stop a live session: deactivate every member, cancel the role's timers.

        Raises:
            LocalProtocolError: no live session of this node has that id.
        """
        session = self._live(sid)
        if session is None:
            raise LocalProtocolError(f"unknown session {sid!r} on node {self._node_id!r}")
        session.stopped = True
        for member in list(session.members.values()):
            # The role asked for the stop: it hears no out_group for it (DESIGN.md).
            self._remove(session, member, deactivate_at=now, notify=False, why=OutReason.STOPPED)
        session.declined.clear()
        self._role_timers.cancel(SessionOwner(session.sid))
        self._maybe_forget(session)

    def stop_all(self, now: float) -> None:
        """Stop every live session (the node leaves)."""
        for session in list(self._sessions.values()):
            if not session.stopped:
                self.stop(session.sid, now)

    def send(self, sid: str, participant: ParticipantRef, message: Any, now: float) -> bool:
        """Send a role message to a joined member.

        Returns:
            False, with nothing sent, when ``participant`` is no joined member or its
            channel's send buffer is full (docs/protocol.md §4).

        Raises:
            LocalProtocolError: ``participant`` belongs to another session.
            NotPlainDataError, InvalidValueError: ``message`` is not plain data or too
                large; checked even when nothing would be sent, so a bad message fails
                the same way whatever the membership.
        """
        _, member = self._member(sid, participant)
        if member is None or not member.joined:
            codec.encode_value(message)
            return False
        channel = member.channel
        return self._channels.send(member.node, channel, FrameKind.ROLE, message, now, limited=True)

    def release(self, sid: str, participant: ParticipantRef, now: float) -> bool:
        """Deactivate one member, pending or joined (reason ``RELEASED``; no ``out_group``:
        the role asked). It is not asked again until it stops matching and matches anew.
        False when it is no member; ``LocalProtocolError`` when of another session."""
        session, member = self._member(sid, participant)
        if session is None or member is None:
            return False
        self._remove(session, member, deactivate_at=now, notify=False, why=OutReason.RELEASED)
        session.declined.add(member.node)  # as a declined node: not asked while it matches
        return True

    def _member(self, sid: str, ref: ParticipantRef) -> tuple[Any, MemberState | None]:
        if ref.session_id != sid:
            raise LocalProtocolError(f"{ref} is not a participant of {sid!r}")
        session = self._live(sid)
        return session, None if session is None else session.members.get(ref.node_id)

    def members_of(self, sid: str) -> MemberSet:
        """The joined members of a session, in node-id order (empty once it stopped)."""
        session = self._live(sid)
        members = () if session is None else session.members.values()
        return MemberSet(ParticipantRef(m.node, sid) for m in members if m.joined)

    # ------------------------------------------------------------------ the view moved

    def reevaluate_all(self, now: float) -> None:
        """This node's own properties changed: every session re-resolves its group."""
        for session in list(self._sessions.values()):
            if not session.stopped:
                self._reevaluate(session, now)

    def node_changed(self, node: str, now: float) -> None:
        """``node``'s properties changed, or it left the view: re-check it everywhere."""
        # The hot path of a large network: every changed node lands here once per
        # session, so the common outcome (no change of membership) costs two lookups.
        for session in list(self._sessions.values()):
            if session.stopped:
                continue
            if self._view.matches(session.definition, self._own, node, session.sid):
                if node not in session.members and node not in session.declined:
                    self._activate(session, node, now)
            elif node in session.members or node in session.declined:
                self._unmatched(session, node, now)

    def peer_gone(self, node: str, failed_at: float | None) -> None:
        """``node`` left (``failed_at`` None) or was found failed at ``failed_at``: it
        leaves every session at once.

        A node that left ended its roles itself. One found failed may only be cut off
        one way (failure detection is local): it is deactivated all the same, and its
        closing channels keep retransmitting, so if it still hears us its role ends too.
        """
        for session in list(self._sessions.values()):
            member = session.members.get(node)
            if member is not None:
                self._remove(session, member, deactivate_at=failed_at, why=OutReason.UNREACHABLE)
            if failed_at is None:
                session.close(node)
            session.declined.discard(node)
            self._maybe_forget(session)

    def _reevaluate(self, session: SessionState, now: float) -> None:
        nodes = set(self._view.candidates(session.definition, self._own))
        nodes.update(session.members)
        nodes.update(session.declined)
        ordered = sorted(nodes)  # never set order (STYLE.md §7)
        # Decided in one pass, then acted on in order: definitions are pure, and
        # neither an activation nor a removal changes the view or our properties.
        matching = self._view.matching(session.definition, self._own, ordered, session.sid)
        for node in ordered:
            self._apply(session, node, node in matching, now)

    def _evaluate(self, session: SessionState, node: str, now: float) -> None:
        matched = self._view.matches(session.definition, self._own, node, session.sid)
        self._apply(session, node, matched, now)

    def _apply(self, session: SessionState, node: str, matched: bool, now: float) -> None:
        """Activate a matching node that is no member (nor declined); remove one that
        no longer matches."""
        if matched:
            if node not in session.members and node not in session.declined:
                self._activate(session, node, now)
        elif node in session.members or node in session.declined:
            self._unmatched(session, node, now)

    def _unmatched(self, session: SessionState, node: str, now: float) -> None:
        """``node`` does not (or no longer) satisfy the definition."""
        session.declined.discard(node)
        member = session.members.get(node)
        if member is not None:
            self._remove(session, member, deactivate_at=now, why=OutReason.LEFT_GROUP)

    def _activate(self, session: SessionState, node: str, now: float) -> None:
        epoch = session.epochs.get(node, 0) + 1
        session.epochs[node] = epoch
        channel = self._channels.open(to_participant=True, session=session.number, epoch=epoch)
        session.members[node] = MemberState(node, epoch, channel)
        payload = [session.participant_role, type(session.role).__name__]
        self._channels.send(node, channel, FrameKind.ACTIVATE, payload, now)

    def _remove(
        self,
        session: SessionState,
        member: MemberState,
        *,
        deactivate_at: float | None,
        notify: bool = True,
        why: OutReason = OutReason.STOPPED,
    ) -> None:
        """Drop a member; with ``deactivate_at``, tell it why (the peer is still there)."""
        del session.members[member.node]
        channel = member.channel
        if deactivate_at is not None and not channel.broken:
            deactivate = FrameKind.DEACTIVATE
            self._channels.send(member.node, channel, deactivate, why.value, deactivate_at)
            session.closing[(member.node, member.epoch)] = channel
        else:
            channel.closed = True
        if member.joined and notify:
            ref = ParticipantRef(member.node, session.sid)
            self._outbox.call(session.role.out_group, (ref,), session.sid)

    def probe(self, now: float, every: float) -> None:
        """Send ``PROBE`` to the idle members of each live session, once every ``every``
        seconds: one that no longer knows the channel answers ``LEFT`` (§3)."""
        for session in self._sessions.values():
            if not session.stopped:
                for member in session.to_probe(now, every):
                    self._channels.send(member.node, member.channel, FrameKind.PROBE, None, now)

    def _maybe_forget(self, session: SessionState) -> None:
        if session.done:
            self._sessions.pop(session.number, None)

    # ------------------------------------------------------------------ frames

    def on_frame(self, source: str, frame: ChannelData, now: float) -> bool:
        """A frame from a participant to one of our sessions; False when it was not one
        of our channels' (dropped and counted)."""
        session = self._sessions.get(frame.session)
        if session is None:
            self._outbox.count("dropped_unknown_session")
            return False
        if frame.kind is FrameKind.LEFT:
            self._on_left(session, source, frame.epoch, now)
            # Acked with its own number (past the stream), so its sender stops repeating it.
            self._channels.acknowledge(
                source, ChannelAck(True, frame.session, frame.epoch, frame.seq)
            )
            return True
        member = session.members.get(source)
        if member is None or member.epoch != frame.epoch:
            return self._on_stray_frame(session, source, frame)
        deliver, ack = member.channel.on_data(frame)
        self._channels.acknowledge(source, ack)
        for item in deliver:
            if session.members.get(source) is not member:
                self._outbox.count("dropped_non_member")
                continue
            self._on_member_said(session, member, item)
        return True

    def _on_left(self, session: SessionState, source: str, epoch: int, now: float) -> None:
        """The participant ended its role on its own (it took us for failed)."""
        member = session.members.get(source)
        if member is not None and member.epoch == epoch:
            self._remove(session, member, deactivate_at=None)
            if not session.stopped:
                self._evaluate(session, source, now)  # still matching: a fresh activation
        session.close(source, epoch)
        self._maybe_forget(session)

    def _on_stray_frame(self, session: SessionState, source: str, frame: ChannelData) -> bool:
        closing = session.closing.get((source, frame.epoch))
        if closing is not None:
            # Guarantee 1: a removed participant's late frames are acked, never delivered.
            _, ack = closing.on_data(frame)
            self._channels.acknowledge(source, ack)
            self._outbox.count("dropped_non_member")
            return True
        if source in session.declined and session.epochs.get(source) == frame.epoch:
            # Our ack of its DECLINED was lost: ack again so it can forget us.
            self._channels.acknowledge(
                source, ChannelAck(True, frame.session, frame.epoch, frame.seq)
            )
            return True
        self._outbox.count("dropped_unknown_session")
        return False

    def _on_member_said(
        self, session: SessionState, member: MemberState, frame: ChannelData
    ) -> None:
        ref = ParticipantRef(member.node, session.sid)
        match frame.kind:
            case FrameKind.ACTIVATED if not member.joined:
                member.joined = True
                self._outbox.call(session.role.in_group, (ref,), session.sid)
            case FrameKind.DECLINED if not member.joined:
                # Guarantee 3: the initiator never hears of a node that declined.
                del session.members[member.node]
                member.channel.closed = True
                session.declined.add(member.node)
            case FrameKind.ROLE if member.joined and not session.stopped:
                self._outbox.call(session.role.receive, (ref, frame.payload), session.sid)
            case _:
                self._outbox.count("dropped_unexpected_frame")

    def on_ack(self, source: str, ack: ChannelAck, now: float) -> bool:
        """A participant acknowledged frames of one of our channels; False when it was
        no channel of ours (dropped and counted)."""
        session = self._sessions.get(ack.session)
        member = None if session is None else session.members.get(source)
        if member is not None and member.epoch == ack.epoch:
            self._channels.on_ack(source, member.channel, ack.ack, now)
            return True
        closing = None if session is None else session.closing.get((source, ack.epoch))
        if session is None or closing is None:
            self._outbox.count("dropped_stray_ack")
            return False
        self._channels.on_ack(source, closing, ack.ack, now)
        if closing.idle:
            del session.closing[(source, ack.epoch)]
            closing.closed = True
            self._maybe_forget(session)
        return True

    def channel_broken(self, target: str, channel: Channel, now: float) -> None:
        """``target`` never acknowledged: it is gone from this channel's session. One
        heard from meanwhile no longer knows the session (it ended its role, and its
        LEFT was lost): if it still matches, it is asked afresh, as after its LEFT."""
        session = self._sessions.get(channel.session)
        if session is None:
            return
        member = session.members.get(target)
        if member is not None and member.channel is channel:
            self._remove(session, member, deactivate_at=None)
            heard = self._view.last_heard(target)
            if not session.stopped and heard is not None and heard > now - channel.break_span():
                self._evaluate(session, target, now)
        if session.closing.get((target, channel.epoch)) is channel:
            del session.closing[(target, channel.epoch)]
        channel.closed = True
        self._maybe_forget(session)

    # ------------------------------------------------------------------ introspection

    def _live(self, sid: str) -> SessionState | None:
        session = self._sessions.get(session_number(sid, self._node_id))
        return None if session is None or session.stopped else session

    def role_of(self, sid: str) -> Initiator | None:
        """The initiator role of a live session, if any."""
        session = self._live(sid)
        return None if session is None else session.role

    def infos(self) -> list[SessionInfo]:
        """Live sessions, oldest first."""
        return [s.info(self._node_id) for s in self._sessions.values() if not s.stopped]

    def counts(self) -> dict[str, int]:
        """Sizes of the per-session structures (all 0 once everything is stopped)."""
        return session_counts(self._sessions.values())
