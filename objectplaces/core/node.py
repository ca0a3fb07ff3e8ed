"""The node machine: everything one ObjectPlaces node decides, without doing any I/O.

``NodeMachine`` is a router: each input goes to the parts that own the state it
concerns, in an order fixed here and nowhere else (§ are docs/protocol.md sections):

* ``OwnProperties``: this node's values, coalescing, publication routing (§2, §5);
* ``Liveness``: the heartbeat and the liveness beat (§2);
* ``PropertyView``: the others' values, liveness, spatial index, scope (§2, §5, §6);
* ``SessionTable``: sessions this node initiated, members, closing channels (§3);
* ``ParticipationTable``: roles this node plays for others, tombstones (§3);
* ``Channels``: reliable frames on the wire, flow control, retransmission (§4);
* ``Intake``: frames refused at the boundary, counted per peer (§7);
* ``TimerQueue``: what is due when (typed ``TimerAction`` values);
* ``Outbox``: frames, callbacks and counters for the driver.

The driver contract (STYLE.md §1): inputs are commands (``update_property``,
``start_session`` ...), frames from peers (``receive``) and the passing of time
(``tick``), each carrying ``now``; after each input the driver drains
``messages_to_send()`` and ``events_received()`` and reads ``next_deadline()``.

Why departures are the router's: a node that fails or leaves (``_depart``) concerns the
view (forget it), the initiator side (it leaves every session; nothing to deactivate),
the participant side (our roles in its sessions end) and the application (departure
observers get its last properties). Each part does its share; only the router knows all
four and the order: state first, callbacks after, so an observer sees the node gone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any, assert_never

from objectplaces.core import codec
from objectplaces.core.bindings import DriverLink, InitiatorContext, ParticipantContext
from objectplaces.core.config import NodeConfig, ParticipationInfo, SessionInfo
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.events import Broadcast, Callback, Output, Subscribe, TimerHandle
from objectplaces.core.groups import DefinitionLike
from objectplaces.core.ids import SessionId
from objectplaces.core.intake import Intake
from objectplaces.core.introspection import Introspection
from objectplaces.core.liveness import Liveness
from objectplaces.core.messages import (
    Beat,
    ChannelAck,
    ChannelData,
    Leave,
    Message,
    PropertyRequest,
    PropertyUpdate,
    Unusable,
)
from objectplaces.core.observers import Observers
from objectplaces.core.own import OwnProperties
from objectplaces.core.participations import ParticipantFactory, ParticipationTable
from objectplaces.core.plumbing import Plumbing
from objectplaces.core.roles import Initiator
from objectplaces.core.sessions import SessionTable
from objectplaces.core.timers import (
    CheckLiveness,
    ExpireTombstone,
    RepeatLeft,
    Republish,
    Retransmit,
    RoleOwner,
    RunTimer,
    SendBeat,
    TimerAction,
)
from objectplaces.core.values import POSITION
from objectplaces.core.view import PropertyCheck, PropertyView

__all__ = ["NodeConfig", "NodeMachine", "ParticipationInfo", "SessionInfo"]


class NodeMachine(Introspection):
    """One node's middleware state and decisions (sans-I/O); what it shows of itself
    (``sessions``, ``counters``, ``footprint`` ...) is ``Introspection``'s.

    Args:
        node_id: this node's id, unique in the network.
        now: the time at creation.
        config: tunables (see ``NodeConfig``).
        space: the node's tuplespace, handed to roles as ``space``.

    Raises:
        LocalProtocolError: ``node_id`` is not a non-empty string.
    """

    def __init__(
        self,
        node_id: str,
        *,
        now: float = 0.0,
        config: NodeConfig | None = None,
        space: Any = None,
    ) -> None:
        if not node_id or not isinstance(node_id, str):
            raise LocalProtocolError(f"node id must be a non-empty string, got {node_id!r}")
        self.node_id = node_id
        self.config = config = config or NodeConfig()
        self.space = space
        self._now = now
        #: The driver's clock and wake for role code; its runtime sets them.
        self.driver = DriverLink(lambda: self._now)
        plumbing = Plumbing.build(node_id, config)
        self._outbox = outbox = plumbing.outbox
        self._timers = plumbing.timers
        self._role_timers = plumbing.role_timers
        self._channels = plumbing.channels
        self._own = OwnProperties(config)
        #: Where the application registers property and departure observers.
        self.observers = observers = Observers(outbox)
        self._view = PropertyView(plumbing, observers=observers)
        self._sessions = SessionTable(
            plumbing,
            view=self._view,
            own=self._own.unwrapped,
            binder=lambda sid: InitiatorContext(self, self._sessions, sid),
        )
        self._participations = ParticipationTable(
            plumbing,
            binder=lambda owner, ref: ParticipantContext(self, self._participations, owner, ref),
        )
        self._intake = Intake(node_id, max_frame=config.max_frame, outbox=outbox)
        #: kind -> [frames, bytes] sent and received (read-only).
        self.sent_by_kind: Mapping[str, list[int]] = MappingProxyType(outbox.sent_by_kind)
        self.received_by_kind = MappingProxyType(self._intake.received_by_kind)
        if config.interest_radius is None:
            outbox.emit(Subscribe(None))
        self._liveness = Liveness(config, self._own, outbox, plumbing.timers, now)

    @property
    def now(self) -> float:
        """The time of the latest input."""
        return self._now

    # ------------------------------------------------------------------ driver side

    def messages_to_send(self) -> list[Output]:
        """Take the frames to transmit (pending property changes are published first)."""
        outbox = self._outbox
        if self._own.pending:
            outbox.emit(self._own.take_update())
            self._liveness.published(self._now)
        out, outbox.outputs = outbox.outputs, []
        return out

    def events_received(self) -> list[Callback]:
        """Take the callbacks to run, in order."""
        outbox = self._outbox
        events, outbox.callbacks = outbox.callbacks, []
        return events

    def has_work(self) -> bool:
        """True when a drain would find outputs, callbacks or a moved deadline."""
        outbox = self._outbox
        return bool(outbox.outputs or outbox.callbacks or self._own.pending or self._timers.changed)

    def next_deadline(self) -> float | None:
        """When ``tick`` must next be called (None: no timer pending)."""
        self._timers.changed = False
        return self._timers.next_deadline()

    def tick(self, now: float) -> None:
        """Let time pass: retransmit, republish, detect failures, fire role timers."""
        self._now = now
        while (action := self._timers.pop_due(now)) is not None:
            self._fire(action)

    def receive(self, source: str, data: bytes, now: float) -> None:
        """Take one frame from ``source``; malformed input is counted and dropped."""
        self._now = now
        message = self._intake.decode(source, data, now)
        if message is not None:
            self.receive_message(source, message, now, size=len(data))

    def receive_message(self, source: str, message: Message, now: float, *, size: int = 0) -> None:
        """Take one already decoded message from ``source`` (``size``: its frame's bytes)."""
        self._now = now
        if type(message) is Beat:
            # The most frequent frame of a quiet network (one per listener per beat
            # interval): tallied and handed to the view without the dispatch below.
            if self._intake.admit_beat(source, size):
                self._view.beat(source, message.seq, now, message.rest)
            return
        if not self._intake.admit(source, message, size):
            return
        accepted = False
        match message:
            case PropertyUpdate():
                self._on_properties(source, message, now)
            case Beat(seq, rest):  # second: the most frequent frame of an idle network
                self._view.beat(source, seq, now, rest)
            case ChannelData(to_participant=True):
                accepted = self._participations.on_frame(source, message, now)
            case ChannelData():
                accepted = self._sessions.on_frame(source, message, now)
            case ChannelAck(of_participant_stream=True):
                accepted = self._participations.on_ack(source, message, now)
            case ChannelAck():
                accepted = self._sessions.on_ack(source, message, now)
            case PropertyRequest():
                self.send_properties_to(source, now)
            case Leave():
                self._depart(source, "left")
            case Unusable(reason):
                self._intake.drop(source, "dropped_invalid_property", reason, now)
            case _:
                assert_never(message)
        if accepted:
            # A frame of one of our channels proves its peer alive (§2). Only such a
            # frame: a stray one, of any claimed sender, must not add to the table.
            self._view.heard(source, now)

    def peer_restarted(self, peer: str, now: float) -> None:
        """``peer`` is back as a new run: forget the old run's groups, sequence numbers
        and closed channels, so the new run's properties and sessions count at once."""
        self._now = now
        self._depart(peer, "restarted")
        self._participations.forget_tombstones_of(peer)

    def peer_joined(self, peer: str, now: float) -> None:
        """A peer (re)connected: send it our properties so its view is complete at once."""
        self.send_properties_to(peer, now)

    def send_properties_to(self, peer: str, now: float) -> None:
        """Send all our properties to one peer (a newcomer, or a new subscriber of our cell)."""
        self._now = now
        if peer != self.node_id:
            self._outbox.emit(self._own.full_update_for(peer))
            self._liveness.sent_snapshot(peer)

    def record_sent(self, kind: str, frames: int, size: int) -> None:
        """Count ``frames`` frames of ``size`` bytes each that the transport put on the wire."""
        self._outbox.record_sent(kind, frames, size)

    def leave(self, now: float) -> None:
        """Leave on purpose: stop our sessions, drop our roles, tell every peer."""
        self._now = now
        self._sessions.stop_all(now)
        self._participations.end_all(now)
        self._outbox.emit(Broadcast(codec.encode(Leave()), "leave"))

    # ------------------------------------------------------------------ properties

    def update_property(self, name: str, value: Any, now: float) -> None:
        """Set one of this node's own properties; it is published at the next drain.

        Raises:
            InvalidValueError: a bad name or an unacceptable value (values.py).
            NotPlainDataError: a value that is not plain data. Nothing changes then.
        """
        value = self._own.set(name, value)
        self._now = now
        self.observers.property_changed(self.node_id, name, value)
        if name == POSITION:
            cells = self._own.new_subscription()
            if cells is not None:
                self._outbox.emit(Subscribe(cells))
                for node in self._view.set_scope(cells):
                    self._forget(node)
        self._sessions.reevaluate_all(now)

    def set_at_rest(self, at_rest: bool, now: float) -> None:
        """Say whether this node is at rest: standing still with nothing to publish (a
        parked vehicle). At rest it beats every ``rest_beat_interval`` instead of every
        ``beat_interval``, and its peers wait for it that much longer before counting it
        failed (docs/protocol.md §2); without a ``rest_beat_interval`` nothing changes.
        """
        self._now = now
        self._liveness.set_at_rest(bool(at_rest))

    @property
    def properties(self) -> Mapping[str, Any]:
        """This node's own properties (read-only)."""
        return self._own.values

    def view(self) -> Mapping[str, Mapping[str, Any]]:
        """The latest known properties of every other node this node hears (read-only)."""
        return self._view.mapping

    def set_property_check(self, check: PropertyCheck | None) -> None:
        """Check every changed property value of a peer before taking it (see
        ``PropertyView``); a refused value is dropped, counted per peer and logged."""
        self._view.set_check(check, self._intake.drop)

    def view_group(self, definition: DefinitionLike) -> frozenset[str]:
        """Resolve ``definition`` over the local view, without sending anything."""
        return self._view.group(definition, self._own.unwrapped)

    def _on_properties(self, source: str, update: PropertyUpdate, now: float) -> None:
        view = self._view
        if not view.apply(source, update, now):
            return
        if view.scoped and not view.in_scope(source):
            self._forget(source)  # it moved out of our cells: no update would follow
            return
        self._sessions.node_changed(source, now)

    def _forget(self, node: str) -> None:
        """Drop ``node`` from the view (it left our scope); sessions re-evaluate it. When
        it was last heard stays if we play roles of its: its failure must end them."""
        self._view.forget(node, keep_liveness=self._participations.plays_for(node))
        self._sessions.node_changed(node, self._now)

    def _depart(self, node: str, reason: str) -> None:
        """``node`` failed or left: it leaves every group, as initiator or participant."""
        known, failed = self._view.knows(node), reason == "failed"
        last = self._view.forget(node)
        self._sessions.peer_gone(node, self._now if failed else None)
        self._participations.initiator_gone(node, self._now, failed=failed)
        if known:
            self._outbox.count(f"departed_{reason}")
            self.observers.departed(node, last or {})

    # ------------------------------------------------------------------ sessions

    def set_factory(self, name: str, factory: ParticipantFactory | None) -> None:
        """Register (or, with None, remove) the factory of participant role ``name``.

        Raises:
            LocalProtocolError: a bad name, or a factory that is not callable.
        """
        self._participations.set_factory(name, factory)

    @property
    def factories(self) -> Mapping[str, ParticipantFactory]:
        """Participant role names this node can play, with their factories."""
        return MappingProxyType(dict(self._participations.factories))

    def start_session(
        self, role: Initiator, definition: DefinitionLike, participant_role: str, now: float
    ) -> SessionId:
        """Start an interaction session with ``role`` as initiator.

        Raises:
            LocalProtocolError: a bad argument, or ``role`` already plays in a session.
        """
        self._now = now
        return self._sessions.open(role, definition, participant_role, now)

    def stop_session(self, sid: str, now: float) -> None:
        """Stop a session started here: deactivate every participant.

        Raises:
            LocalProtocolError: no live session of this node has that id.
        """
        self._now = now
        self._sessions.stop(sid, now)

    def call_later(
        self, delay: float, fn: Callable[[], Any], now: float, *, owner: RoleOwner | None = None
    ) -> TimerHandle:
        """Run ``fn`` at ``now + delay`` (as an event); cancelled when ``owner`` ends.

        Raises:
            LocalProtocolError: ``delay`` is negative or not a number.
        """
        self._now = now
        return self._role_timers.schedule(now, delay, fn, owner)

    # ------------------------------------------------------------------ timers

    def _fire(self, action: TimerAction) -> None:
        now = self._now
        match action:
            case RunTimer(handle):
                if self._role_timers.fire(handle):
                    owner = handle.owner
                    self._outbox.call(handle.fn, (), "" if owner is None else owner.session_id)
            case Retransmit(target, channel, at):
                if not channel.closed and self._channels.retransmit(target, channel, at, now):
                    if channel.outbound_to_participant:
                        self._sessions.channel_broken(target, channel, now)
                    else:
                        self._participations.channel_broken(target, channel, now)
            case Republish():
                self._liveness.republish(action, now)
            case SendBeat():
                self._liveness.beat(action, now)
            case CheckLiveness(timeout):
                view, parts = self._view, self._participations
                for node in view.silent_since(now - timeout):
                    if view.props_of(node) is None and not parts.plays_for(node):
                        view.forget(node)  # kept only for its roles, which ended
                    else:
                        self._depart(node, "failed")
                for node in view.silent_since(now - timeout, stale=True):
                    view.ask_snapshot(node, now)  # alive, but its properties stopped coming
                if self.config.probe_interval is not None:
                    self._sessions.probe(now, self.config.probe_interval)
                self._timers.push(now + timeout / 3, action)
            case ExpireTombstone(initiator, session):
                self._participations.expire_tombstone(initiator, session, now)
            case RepeatLeft():
                self._participations.repeat_left(action, now)
            case _:
                assert_never(action)
