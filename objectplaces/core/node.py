"""The node machine: everything one ObjectPlaces node decides, without doing any I/O.

Inputs are API commands (``update_property``, ``start_session`` ...), frames from peers
(``receive``), and the passing of time (``tick``); every input carries ``now``. After
each input the driver drains ``messages_to_send()`` and ``events_received()`` and reads
``next_deadline()``. The same machine runs under the simulated network and the asyncio
WebSocket mesh.

Sections of the paper each part implements: property dissemination and the local view
("Architecture and implementation"), group formation ("Interaction session setup"),
group maintenance and the two membership guarantees ("Interaction session
maintenance"), and routing of messages to roles ("Application programming interface").
"""

from __future__ import annotations

import heapq
import itertools
import logging
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from objectplaces.core import codec
from objectplaces.core.channel import Channel
from objectplaces.core.errors import DecodeError, LocalProtocolError
from objectplaces.core.events import (
    Broadcast,
    Callback,
    Output,
    Publish,
    Send,
    Subscribe,
    TimerHandle,
)
from objectplaces.core.groups import DefinitionLike, GroupDefinition
from objectplaces.core.ids import InitiatorRef, ParticipantRef, SessionId, session_id_for
from objectplaces.core.messages import (
    ChannelAck,
    ChannelData,
    FrameKind,
    Leave,
    Message,
    PropertyUpdate,
)
from objectplaces.core.roles import Initiator, Participant
from objectplaces.core.spatial import GridIndex, RunningMax

__all__ = ["NodeConfig", "NodeMachine", "ParticipationInfo", "SessionInfo"]

log = logging.getLogger("objectplaces")

Cell = tuple[int, int]
ParticipantFactory = Callable[[], Participant]
PropertyObserver = Callable[[str, str, Any], Any]
DepartureObserver = Callable[[str, Mapping[str, Any]], Any]


@dataclass(frozen=True, slots=True)
class NodeConfig:
    """Tunables of one node; every duration is in seconds.

    Attributes:
        property_interval: republish all properties this often (the heartbeat); None: never.
        failure_timeout: a node not heard for this long leaves every group; None: three
            property intervals when those are on, else no failure detection.
        interest_radius: scoped dissemination: hear only nodes within about this
            distance (None: hear every node, the paper's behaviour).
        cell_size: side of the grid cells used for dissemination scopes and the index.
        retransmit_timeout: first retransmission of an unacknowledged channel frame.
        max_retransmissions: tries before a channel counts as broken (its peer gone).
        tombstone_ttl: how long a closed channel is remembered to drop its late frames.
        max_frame: largest frame accepted, in bytes.
    """

    property_interval: float | None = None
    failure_timeout: float | None = None
    interest_radius: float | None = None
    cell_size: float = 25.0
    retransmit_timeout: float = 0.2
    max_retransmissions: int = 12
    tombstone_ttl: float = 10.0
    max_frame: int = codec.DEFAULT_MAX_FRAME

    @property
    def effective_failure_timeout(self) -> float | None:
        """The failure timeout in force (explicit, or three property intervals)."""
        if self.failure_timeout is not None:
            return self.failure_timeout
        return None if self.property_interval is None else 3 * self.property_interval


@dataclass(frozen=True, slots=True)
class SessionInfo:
    """A session this node initiated, as introspection shows it."""

    session_id: str
    initiator: str
    initiator_role: str
    participant_role: str
    members: frozenset[str]
    pending: frozenset[str]
    started_at: float
    definition: Any


@dataclass(frozen=True, slots=True)
class ParticipationInfo:
    """A participant role active on this node."""

    session_id: str
    initiator: str
    participant_role: str
    since: float


_PENDING, _MEMBER = 0, 1


@dataclass(slots=True)
class _Member:
    node: str
    epoch: int
    channel: Channel
    state: int = _PENDING


@dataclass(slots=True)
class _Session:
    number: int
    sid: SessionId
    role: Initiator
    definition: DefinitionLike
    participant_role: str
    started_at: float
    members: dict[str, _Member] = field(default_factory=dict)
    closing: dict[tuple[str, int], Channel] = field(default_factory=dict)
    declined: set[str] = field(default_factory=set)
    epochs: dict[str, int] = field(default_factory=dict)
    stopped: bool = False


@dataclass(slots=True)
class _Participation:
    initiator: str
    session: int
    epoch: int
    channel: Channel
    ref: InitiatorRef
    since: float
    role: Participant | None = None
    role_name: str = ""
    declining: bool = False


class _InitiatorBinding:
    """Connects an initiator role to its session inside the machine."""

    def __init__(self, machine: NodeMachine, session: _Session) -> None:
        self._machine = machine
        self._session = session
        self.node_id = machine.node_id
        self.session_id = session.sid
        self.space = machine.space

    def now(self) -> float:
        return self._machine.now

    def call_later(self, delay: float, fn: Callable[[], Any]) -> TimerHandle:
        return self._machine.call_later(delay, fn, owner=("i", self._session.sid))

    def send(self, participant: ParticipantRef, message: Any) -> bool:
        return self._machine._initiator_send(self._session, participant, message)

    def members(self) -> frozenset[ParticipantRef]:
        sid = self._session.sid
        return frozenset(
            ParticipantRef(m.node, sid)
            for m in self._session.members.values()
            if m.state == _MEMBER
        )

    def stop(self) -> None:
        self._machine.stop_session(self._session.sid)


class _ParticipantBinding:
    """Connects a participant role to its channel inside the machine."""

    def __init__(self, machine: NodeMachine, part: _Participation) -> None:
        self._machine = machine
        self._part = part
        self.node_id = machine.node_id
        self.session_id = part.ref.session_id
        self.space = machine.space
        self.initiator = part.ref

    def now(self) -> float:
        return self._machine.now

    def call_later(self, delay: float, fn: Callable[[], Any]) -> TimerHandle:
        key = (self._part.initiator, self._part.session, self._part.epoch)
        return self._machine.call_later(delay, fn, owner=("p", key))

    def send(self, message: Any) -> bool:
        return self._machine._participant_send(self._part, message)


class NodeMachine:
    """One node's middleware state and decisions (sans-I/O).

    Args:
        node_id: this node's id, unique in the network.
        now: the time at creation.
        config: tunables (see ``NodeConfig``).
        space: the node's tuplespace, handed to roles as ``space``.
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
        self.config = config or NodeConfig()
        self.space = space
        self.now = now
        self._own: dict[str, Any] = {}
        self._own_seq = 0
        self._dirty: dict[str, Any] = {}
        self._view: dict[str, dict[str, Any]] = {}
        self._seqs: dict[str, dict[str, int]] = {}
        self._heard: dict[str, float] = {}
        self._indexes: dict[str, GridIndex] = {}
        self._maxima: dict[str, RunningMax] = {}
        self._published_cell: Cell | None = None
        self._subscribed: frozenset[Cell] | None = None
        self._subscribed_bounds: tuple[int, int, int, int] | None = None
        self._factories: dict[str, ParticipantFactory] = {}
        self._sessions: dict[int, _Session] = {}
        self._session_counter = itertools.count(1)
        self._participations: dict[tuple[str, int], _Participation] = {}
        self._tombstones: dict[tuple[str, int], tuple[int, float]] = {}
        self._timers: list[tuple[float, int, Any]] = []
        self._timer_seq = itertools.count()
        self._role_timers: dict[Any, set[TimerHandle]] = {}
        self._outbox: list[Output] = []
        self._events: list[Callback] = []
        self._timers_changed = False
        self._property_observers: list[PropertyObserver] = []
        self._departure_observers: list[DepartureObserver] = []
        self.counters: dict[str, int] = {}
        self.sent_by_kind: dict[str, list[int]] = {}
        self.received_by_kind: dict[str, list[int]] = {}
        if self.config.interest_radius is None:
            self._emit(Subscribe(None))
        if self.config.property_interval is not None:
            self._push_timer(now + self.config.property_interval, ("republish",))
        timeout = self.config.effective_failure_timeout
        if timeout is not None:
            self._push_timer(now + timeout / 3, ("liveness",))

    # ------------------------------------------------------------------ driver side

    def messages_to_send(self) -> list[Output]:
        """Take the frames to transmit (pending property changes are published first)."""
        if self._dirty:
            self._publish(self._dirty)
            self._dirty = {}
        out, self._outbox = self._outbox, []
        return out

    def events_received(self) -> list[Callback]:
        """Take the callbacks to run, in order."""
        events, self._events = self._events, []
        return events

    def has_work(self) -> bool:
        """True when a drain would find outputs, callbacks or a moved deadline."""
        return bool(self._outbox or self._events or self._dirty) or self._timers_changed

    def next_deadline(self) -> float | None:
        """When ``tick`` must next be called (None: no timer pending)."""
        self._timers_changed = False
        timers = self._timers
        while timers and self._timer_dead(timers[0][2]):
            heapq.heappop(timers)
        return timers[0][0] if timers else None

    def tick(self, now: float) -> None:
        """Let time pass: retransmit, republish, detect failures, fire role timers."""
        self.now = now
        timers = self._timers
        while timers and timers[0][0] <= now:
            _, _, action = heapq.heappop(timers)
            self._timers_changed = True
            self._fire(action)

    def receive(self, source: str, data: bytes, now: float) -> None:
        """Take one frame from ``source``; malformed input is counted and dropped."""
        try:
            message = codec.decode(data, max_size=self.config.max_frame)
        except DecodeError as exc:
            self.now = now
            self._count("dropped_malformed")
            log.warning("node %s: dropped a frame from %s: %s", self.node_id, source, exc)
            return
        self.receive_message(source, message, now, size=len(data))

    def receive_message(self, source: str, message: Message, now: float, *, size: int = 0) -> None:
        """Take one already decoded message from ``source`` (``size``: its frame's bytes)."""
        self.now = now
        kind = _message_kind(message)
        tally = self.received_by_kind.setdefault(kind, [0, 0])
        tally[0] += 1
        tally[1] += size
        if source == self.node_id:
            self._count("dropped_own")
            return
        match message:
            case PropertyUpdate():
                self._on_properties(source, message)
            case ChannelData(to_participant=True):
                self._heard_from(source)
                self._on_participant_frame(source, message)
            case ChannelData():
                self._heard_from(source)
                self._on_initiator_frame(source, message)
            case ChannelAck():
                self._heard_from(source)
                self._on_ack(source, message)
            case Leave():
                self._depart(source, reason="left")

    def peer_restarted(self, peer: str, now: float) -> None:
        """``peer`` is back as a new run: forget the old run's groups, sequence numbers
        and closed channels, so the new run's properties and sessions count at once."""
        self.now = now
        self._depart(peer, reason="restarted")
        for key in [k for k in self._tombstones if k[0] == peer]:
            del self._tombstones[key]

    def peer_joined(self, peer: str, now: float) -> None:
        """A peer (re)connected: send it our properties so its view is complete at once."""
        self.now = now
        self.send_properties_to(peer)

    def send_properties_to(self, peer: str) -> None:
        """Send all our properties to one peer (a newcomer, or a new subscriber of our cell)."""
        if self._own and peer != self.node_id:
            self._own_seq += 1
            data = codec.encode(PropertyUpdate(self._own_seq, dict(self._own)))
            self._emit(Send(peer, data, "property"))

    # ------------------------------------------------------------------ properties

    def update_property(self, name: str, value: Any, now: float) -> None:
        """Set one of this node's own properties; it is published at the next drain.

        Raises:
            LocalProtocolError: the name is not a non-empty string or the value not plain data.
        """
        if not isinstance(name, str) or not name:
            raise LocalProtocolError(f"property name must be a non-empty string, got {name!r}")
        codec.encode_value(value)
        self.now = now
        value = codec.normalise_property(name, value)
        self._own[name] = value
        self._dirty[name] = value
        self._notify_property(self.node_id, name, value)
        self._after_own_change(name)

    @property
    def properties(self) -> Mapping[str, Any]:
        """This node's own properties."""
        return self._own

    def view(self) -> Mapping[str, Mapping[str, Any]]:
        """The latest known properties of every other node this node hears."""
        return self._view

    def add_property_observer(self, observer: PropertyObserver) -> Callable[[], None]:
        """Call ``observer(node_id, name, value)`` on every local and remote change."""
        self._property_observers.append(observer)
        return lambda: _discard(self._property_observers, observer)

    def add_departure_observer(self, observer: DepartureObserver) -> Callable[[], None]:
        """Call ``observer(node_id, last_properties)`` when a node fails or leaves."""
        self._departure_observers.append(observer)
        return lambda: _discard(self._departure_observers, observer)

    def _notify_property(self, node: str, name: str, value: Any) -> None:
        for observer in self._property_observers:
            self._events.append(Callback(observer, (node, name, value)))

    def _publish(self, values: Mapping[str, Any]) -> None:
        self._own_seq += 1
        data = codec.encode(PropertyUpdate(self._own_seq, dict(values)))
        self._route_publication(data)

    def _route_publication(self, data: bytes) -> None:
        cell = self._own_cell()
        if self.config.interest_radius is None or cell is None:
            self._emit(Broadcast(data, "property"))
            return
        cells = (cell,) if self._published_cell in (None, cell) else (cell, self._published_cell)
        self._published_cell = cell
        self._emit(Publish(cells, data, "property"))

    def _own_cell(self) -> Cell | None:
        position = self._own.get(codec.POSITION)
        if not isinstance(position, tuple):
            return None
        size = self.config.cell_size
        return (math.floor(position[0] / size), math.floor(position[1] / size))

    def _update_subscription(self) -> None:
        radius = self.config.interest_radius
        if radius is None:
            return
        position = self._own.get(codec.POSITION)
        if not isinstance(position, tuple):
            return
        size = self.config.cell_size
        x, y = position
        bounds = (
            math.floor((x - radius) / size),
            math.floor((y - radius) / size),
            math.floor((x + radius) / size),
            math.floor((y + radius) / size),
        )
        if bounds == self._subscribed_bounds:
            return
        self._subscribed_bounds = bounds
        x0, y0, x1, y1 = bounds
        cells = frozenset((cx, cy) for cx in range(x0, x1 + 1) for cy in range(y0, y1 + 1))
        self._subscribed = cells
        self._emit(Subscribe(cells))
        for node in [n for n in self._view if not self._in_scope(n)]:
            self._forget(node)

    def _in_scope(self, node: str) -> bool:
        """Whether we still hear ``node`` under scoped dissemination."""
        if self._subscribed is None:
            return True
        position = self._view[node].get(codec.POSITION)
        if not isinstance(position, tuple):
            return True
        size = self.config.cell_size
        return (math.floor(position[0] / size), math.floor(position[1] / size)) in self._subscribed

    def _after_own_change(self, name: str) -> None:
        if name == codec.POSITION:
            self._update_subscription()
        for session in list(self._sessions.values()):
            if not session.stopped:
                self._reevaluate_all(session)

    def _on_properties(self, source: str, update: PropertyUpdate) -> None:
        # The hottest path of a large network: every delivered update comes through here.
        self._heard[source] = self.now
        props = self._view.get(source)
        if props is None:
            props = self._view[source] = {}
            self._seqs[source] = {}
        seqs = self._seqs[source]
        seq = update.seq
        changed = moved = False
        indexes, maxima, observers = self._indexes, self._maxima, self._property_observers
        for name, value in update.values.items():
            if seq <= seqs.get(name, -1):
                continue
            seqs[name] = seq
            if name in props and props[name] == value:
                continue
            props[name] = value
            changed = True
            if name == codec.POSITION:
                moved = True
            if name in indexes or name in maxima:
                self._index_property(source, name, value)
            if observers:
                self._notify_property(source, name, value)
        if not changed:
            return
        if moved and self._subscribed is not None and not self._in_scope(source):
            self._forget(source)
            return
        sessions = self._sessions
        if sessions:
            for session in list(sessions.values()):
                if not session.stopped:
                    self._evaluate(session, source)

    def _index_property(self, node: str, name: str, value: Any) -> None:
        index = self._indexes.get(name)
        if index is not None:
            if isinstance(value, tuple | list) and len(value) == 2:
                index.place(node, float(value[0]), float(value[1]))
            else:
                index.remove(node)
        maximum = self._maxima.get(name)
        if maximum is not None:
            maximum.set(node, float(value) if isinstance(value, int | float) else 0.0)

    def _heard_from(self, source: str) -> None:
        self._heard[source] = self.now

    def _forget(self, node: str) -> None:
        """Drop ``node`` from the view (it left our scope); sessions re-evaluate it."""
        self._view.pop(node, None)
        self._seqs.pop(node, None)
        self._heard.pop(node, None)
        for index in self._indexes.values():
            index.remove(node)
        for maximum in self._maxima.values():
            maximum.remove(node)
        for session in list(self._sessions.values()):
            if not session.stopped:
                self._evaluate(session, node)

    def _depart(self, node: str, *, reason: str) -> None:
        """``node`` failed or left: it leaves every group, as initiator or participant."""
        last = self._view.get(node, {})
        known = node in self._view or node in self._heard
        self._view.pop(node, None)
        self._seqs.pop(node, None)
        self._heard.pop(node, None)
        for index in self._indexes.values():
            index.remove(node)
        for maximum in self._maxima.values():
            maximum.remove(node)
        for session in list(self._sessions.values()):
            member = session.members.get(node)
            if member is not None:
                self._remove_member(session, member, deactivate=False)
            for key in [k for k in session.closing if k[0] == node]:
                del session.closing[key]
            session.declined.discard(node)
            self._maybe_forget_session(session)
        for part in list(self._participations.values()):
            if part.initiator == node:
                self._end_participation(part)
        if known:
            self._count(f"departed_{reason}")
            for observer in self._departure_observers:
                self._events.append(Callback(observer, (node, dict(last))))

    # ------------------------------------------------------------------ groups

    def set_factory(self, name: str, factory: ParticipantFactory | None) -> None:
        """Register (or, with None, remove) the factory of participant role ``name``."""
        if not isinstance(name, str) or not name:
            raise LocalProtocolError(
                f"participant role name must be a non-empty string, got {name!r}"
            )
        if factory is None:
            self._factories.pop(name, None)
        elif not callable(factory):
            raise LocalProtocolError(
                f"participant factory for {name!r} is not callable: {factory!r}"
            )
        else:
            self._factories[name] = factory

    @property
    def factories(self) -> Mapping[str, ParticipantFactory]:
        """Participant role names this node can play, with their factories."""
        return self._factories

    def _index_for(self, position: str) -> GridIndex:
        index = self._indexes.get(position)
        if index is None:
            index = self._indexes[position] = GridIndex(self.config.cell_size)
            for node, props in self._view.items():
                value = props.get(position)
                if isinstance(value, tuple | list) and len(value) == 2:
                    index.place(node, float(value[0]), float(value[1]))
        return index

    def _max_of(self, name: str) -> float:
        maximum = self._maxima.get(name)
        if maximum is None:
            maximum = self._maxima[name] = RunningMax()
            for node, props in self._view.items():
                value = props.get(name)
                maximum.set(node, float(value) if isinstance(value, int | float) else 0.0)
        return maximum.value

    def _candidates(self, definition: DefinitionLike) -> Iterable[str]:
        """Nodes that may satisfy ``definition``: the index's neighbours, or everyone."""
        if isinstance(definition, GroupDefinition):
            reach = definition.reach(self._own, self._max_of)
            if reach is not None:
                position = self._own.get(reach.position)
                if not isinstance(position, tuple | list) or len(position) != 2:
                    return ()
                index = self._index_for(reach.position)
                return index.near(float(position[0]), float(position[1]), reach.radius)
        return self._view.keys()

    def _matches(self, definition: DefinitionLike, node: str, sid: str = "") -> bool:
        props = self._view.get(node)
        if props is None:
            return False
        try:
            return bool(definition(self._own, props))
        except Exception:
            log.exception("node %s: group definition of session %r raised", self.node_id, sid)
            self._count("definition_errors")
            return False

    def view_group(self, definition: DefinitionLike) -> frozenset[str]:
        """Resolve ``definition`` over the local view, without sending anything."""
        return frozenset(n for n in self._candidates(definition) if self._matches(definition, n))

    # ------------------------------------------------------------------ initiator side

    def start_session(
        self, role: Initiator, definition: DefinitionLike, participant_role: str, now: float
    ) -> SessionId:
        """Start an interaction session with ``role`` as initiator.

        Raises:
            LocalProtocolError: a bad argument, or ``role`` already plays in a session.
        """
        if not isinstance(role, Initiator):
            raise LocalProtocolError(f"initiator role must subclass Initiator, got {role!r}")
        if role._binding is not None:
            raise LocalProtocolError(f"{role!r} already plays in session {role.session_id!r}")
        if not callable(definition):
            raise LocalProtocolError(f"group definition must be callable, got {definition!r}")
        if not isinstance(participant_role, str) or not participant_role:
            raise LocalProtocolError(
                f"participant role name must be a non-empty string, got {participant_role!r}"
            )
        self.now = now
        number = next(self._session_counter)
        session = _Session(
            number, session_id_for(self.node_id, number), role, definition, participant_role, now
        )
        self._sessions[number] = session
        role._binding = _InitiatorBinding(self, session)
        self._events.append(Callback(role.started, (), session.sid))
        self._reevaluate_all(session)
        return session.sid

    def stop_session(self, sid: str) -> None:
        """Stop a session started here: deactivate every participant.

        Raises:
            LocalProtocolError: no live session of this node has that id.
        """
        session = self._session_by_id(sid)
        if session is None or session.stopped:
            raise LocalProtocolError(f"unknown session {sid!r} on node {self.node_id!r}")
        session.stopped = True
        for member in list(session.members.values()):
            self._remove_member(session, member, deactivate=True, notify=False)
        session.declined.clear()
        self._cancel_timers(("i", session.sid))
        self._maybe_forget_session(session)

    def _session_by_id(self, sid: str) -> _Session | None:
        prefix, _, number = str(sid).rpartition("#")
        if prefix != self.node_id or not number.isdigit():
            return None
        return self._sessions.get(int(number))

    def _reevaluate_all(self, session: _Session) -> None:
        nodes = set(self._candidates(session.definition))
        nodes.update(session.members)
        nodes.update(session.declined)
        for node in sorted(nodes):
            self._evaluate(session, node)

    def _evaluate(self, session: _Session, node: str) -> None:
        if self._matches(session.definition, node, session.sid):
            if node not in session.members and node not in session.declined:
                self._activate(session, node)
            return
        session.declined.discard(node)
        member = session.members.get(node)
        if member is not None:
            self._remove_member(session, member, deactivate=True)

    def _activate(self, session: _Session, node: str) -> None:
        epoch = session.epochs.get(node, 0) + 1
        session.epochs[node] = epoch
        channel = self._new_channel(True, session.number, epoch)
        session.members[node] = _Member(node, epoch, channel)
        payload = [session.participant_role, type(session.role).__name__]
        self._send_frame(node, channel, FrameKind.ACTIVATE, payload)

    def _remove_member(
        self, session: _Session, member: _Member, *, deactivate: bool, notify: bool = True
    ) -> None:
        del session.members[member.node]
        if deactivate and not member.channel.broken:
            self._send_frame(member.node, member.channel, FrameKind.DEACTIVATE, None)
            session.closing[(member.node, member.epoch)] = member.channel
        if member.state == _MEMBER and notify:
            ref = ParticipantRef(member.node, session.sid)
            self._events.append(Callback(session.role.out_group, (ref,), session.sid))

    def _maybe_forget_session(self, session: _Session) -> None:
        if session.stopped and not session.members and not session.closing:
            self._sessions.pop(session.number, None)

    def _initiator_send(self, session: _Session, participant: ParticipantRef, message: Any) -> bool:
        if participant.session_id != session.sid:
            raise LocalProtocolError(f"{participant} is not a participant of {session.sid!r}")
        member = session.members.get(participant.node_id)
        if member is None or member.state != _MEMBER or session.stopped:
            codec.encode_value(message)
            return False
        self._send_frame(member.node, member.channel, FrameKind.ROLE, message)
        return True

    def _on_initiator_frame(self, source: str, frame: ChannelData) -> None:
        """A frame from a participant to one of our sessions."""
        session = self._sessions.get(frame.session)
        if session is None:
            self._count("dropped_unknown_session")
            return
        member = session.members.get(source)
        if member is not None and member.epoch == frame.epoch:
            channel = member.channel
        else:
            closing = session.closing.get((source, frame.epoch))
            if closing is None:
                if source in session.declined and session.epochs.get(source) == frame.epoch:
                    # Our ack of its DECLINED was lost: ack again so it can forget us.
                    ack = ChannelAck(True, frame.session, frame.epoch, frame.seq)
                    self._emit(Send(source, codec.encode(ack), "ack"))
                    return
                self._count("dropped_unknown_session")
                return
            # Guarantee 1: a removed participant's late frames are acked, never delivered.
            _, ack = closing.on_data(frame)
            self._emit(Send(source, codec.encode(ack), "ack"))
            self._count("dropped_non_member")
            return
        deliver, ack = channel.on_data(frame)
        self._emit(Send(source, codec.encode(ack), "ack"))
        for item in deliver:
            if session.members.get(source) is not member:
                self._count("dropped_non_member")
                continue
            self._on_participant_said(session, member, item)

    def _on_participant_said(self, session: _Session, member: _Member, frame: ChannelData) -> None:
        ref = ParticipantRef(member.node, session.sid)
        match frame.kind:
            case FrameKind.ACTIVATED if member.state == _PENDING:
                member.state = _MEMBER
                self._events.append(Callback(session.role.in_group, (ref,), session.sid))
            case FrameKind.DECLINED if member.state == _PENDING:
                # Guarantee 3: the initiator never hears of a node that declined.
                del session.members[member.node]
                session.declined.add(member.node)
            case FrameKind.ROLE if member.state == _MEMBER and not session.stopped:
                self._events.append(
                    Callback(session.role.receive, (ref, frame.payload), session.sid)
                )
            case _:
                self._count("dropped_unexpected_frame")

    # ------------------------------------------------------------------ participant side

    def _on_participant_frame(self, source: str, frame: ChannelData) -> None:
        """A frame from an initiator to a participant role (to be) on this node."""
        key = (source, frame.session)
        tomb = self._tombstones.get(key)
        if tomb is not None and frame.epoch <= tomb[0]:
            # A closed channel: ack so the initiator stops retransmitting, deliver nothing.
            ack = ChannelAck(False, frame.session, frame.epoch, frame.seq)
            self._emit(Send(source, codec.encode(ack), "ack"))
            self._count("dropped_stale")
            return
        part = self._participations.get(key)
        if part is not None and part.epoch != frame.epoch:
            if frame.epoch < part.epoch:
                self._count("dropped_stale")
                return
            self._end_participation(part)  # a newer activation supersedes the old one
            part = None
        if part is None:
            channel = self._new_channel(False, frame.session, frame.epoch)
            ref = InitiatorRef(source, session_id_for(source, frame.session))
            part = _Participation(source, frame.session, frame.epoch, channel, ref, self.now)
            self._participations[key] = part
        deliver, ack = part.channel.on_data(frame)
        self._emit(Send(source, codec.encode(ack), "ack"))
        for item in deliver:
            if self._participations.get(key) is not part:
                break
            self._on_initiator_said(part, item)

    def _on_initiator_said(self, part: _Participation, frame: ChannelData) -> None:
        match frame.kind:
            case FrameKind.ACTIVATE if part.role is None and not part.declining:
                self._activate_participant(part, frame.payload)
            case FrameKind.ROLE if part.role is not None:
                self._events.append(
                    Callback(part.role.receive, (frame.payload,), part.ref.session_id)
                )
            case FrameKind.DEACTIVATE:
                self._end_participation(part)
            case _:
                self._count("dropped_unexpected_frame")

    def _activate_participant(self, part: _Participation, payload: Any) -> None:
        name = payload[0] if isinstance(payload, list) and payload else None
        factory = self._factories.get(name) if isinstance(name, str) else None
        role: Participant | None = None
        if factory is not None:
            try:
                role = factory()
                if not isinstance(role, Participant):
                    raise TypeError(f"factory for {name!r} returned {role!r}, not a Participant")
            except Exception:
                log.exception("node %s: participant factory %r failed", self.node_id, name)
                role = None
        if role is None:
            part.declining = True
            self._send_frame(part.initiator, part.channel, FrameKind.DECLINED, None)
            return
        part.role = role
        part.role_name = str(name)
        role._binding = _ParticipantBinding(self, part)
        self._send_frame(part.initiator, part.channel, FrameKind.ACTIVATED, None)
        self._events.append(Callback(role.in_group_of, (part.ref,), part.ref.session_id))

    def _participant_send(self, part: _Participation, message: Any) -> bool:
        key = (part.initiator, part.session)
        if self._participations.get(key) is not part or part.role is None:
            codec.encode_value(message)
            return False
        self._send_frame(part.initiator, part.channel, FrameKind.ROLE, message)
        return True

    def _end_participation(self, part: _Participation) -> None:
        key = (part.initiator, part.session)
        if self._participations.get(key) is part:
            del self._participations[key]
        self._tombstones[key] = (part.epoch, self.now + self.config.tombstone_ttl)
        self._push_timer(self.now + self.config.tombstone_ttl, ("tombstone", key))
        self._cancel_timers(("p", (part.initiator, part.session, part.epoch)))
        role = part.role
        if role is not None:
            part.role = None
            self._events.append(Callback(_deactivated, (role, part.ref), part.ref.session_id))

    # ------------------------------------------------------------------ channels

    def _new_channel(self, to_participant: bool, session: int, epoch: int) -> Channel:
        return Channel(
            outbound_to_participant=to_participant,
            session=session,
            epoch=epoch,
            rto=self.config.retransmit_timeout,
            max_tries=self.config.max_retransmissions,
        )

    def _send_frame(self, target: str, channel: Channel, kind: FrameKind, payload: Any) -> None:
        was_idle = channel.idle
        frame = channel.send(kind, payload, self.now)
        data = codec.encode(frame)
        self._emit(Send(target, data, "channel"))
        if was_idle:
            # One timer per channel: _retransmit re-arms it at the next frame's deadline.
            self._push_timer(self.now + self.config.retransmit_timeout, ("retx", target, channel))

    def _on_ack(self, source: str, ack: ChannelAck) -> None:
        if ack.of_participant_stream:
            part = self._participations.get((source, ack.session))
            if part is None or part.epoch != ack.epoch:
                return
            part.channel.on_ack(ack.ack)
            if part.declining and part.channel.idle:
                self._end_participation(part)
            return
        session = self._sessions.get(ack.session)
        if session is None:
            return
        member = session.members.get(source)
        if member is not None and member.epoch == ack.epoch:
            member.channel.on_ack(ack.ack)
            return
        closing = session.closing.get((source, ack.epoch))
        if closing is not None:
            closing.on_ack(ack.ack)
            if closing.idle:
                del session.closing[(source, ack.epoch)]
                self._maybe_forget_session(session)

    def _retransmit(self, target: str, channel: Channel) -> None:
        if not self._channel_live(target, channel):
            return
        for frame in channel.due(self.now):
            self._count("retransmissions")
            self._emit(Send(target, codec.encode(frame), "channel"))
        if channel.broken:
            self._count("channels_broken")
            self._channel_broken(target, channel)
            return
        deadline = channel.deadline()
        if deadline is not None:
            self._push_timer(deadline, ("retx", target, channel))

    def _channel_live(self, target: str, channel: Channel) -> bool:
        if channel.outbound_to_participant:
            session = self._sessions.get(channel.session)
            if session is None:
                return False
            member = session.members.get(target)
            return (member is not None and member.channel is channel) or (
                session.closing.get((target, channel.epoch)) is channel
            )
        part = self._participations.get((target, channel.session))
        return part is not None and part.channel is channel

    def _channel_broken(self, target: str, channel: Channel) -> None:
        """The peer never answered: treat it as gone from this channel's session."""
        if channel.outbound_to_participant:
            session = self._sessions[channel.session]
            member = session.members.get(target)
            if member is not None and member.channel is channel:
                self._remove_member(session, member, deactivate=False)
            session.closing.pop((target, channel.epoch), None)
            self._maybe_forget_session(session)
        else:
            part = self._participations.get((target, channel.session))
            if part is not None:
                self._end_participation(part)

    # ------------------------------------------------------------------ timers

    def call_later(self, delay: float, fn: Callable[[], Any], *, owner: Any = None) -> TimerHandle:
        """Run ``fn`` at ``now + delay`` (as an event); cancelled with its owner role."""
        if not delay >= 0:
            raise LocalProtocolError(f"delay must be >= 0 seconds, got {delay!r}")
        handle = TimerHandle(self.now + delay, fn, owner)
        if owner is not None:
            self._role_timers.setdefault(owner, set()).add(handle)
        self._push_timer(handle.deadline, ("call", handle))
        return handle

    def _cancel_timers(self, owner: Any) -> None:
        for handle in self._role_timers.pop(owner, ()):
            handle.cancelled = True

    def _push_timer(self, deadline: float, action: Any) -> None:
        heapq.heappush(self._timers, (deadline, next(self._timer_seq), action))
        self._timers_changed = True

    def _timer_dead(self, action: Any) -> bool:
        if action[0] == "call":
            return bool(action[1].cancelled)
        if action[0] == "retx":
            return not self._channel_live(action[1], action[2])
        return False

    def _fire(self, action: Any) -> None:
        match action[0]:
            case "call":
                handle: TimerHandle = action[1]
                if handle.cancelled:
                    return
                handle.cancelled = True
                owned = self._role_timers.get(handle.owner)
                if owned is not None:
                    owned.discard(handle)
                    if not owned:
                        del self._role_timers[handle.owner]
                session_id = _owner_session(handle.owner)
                self._events.append(Callback(handle.fn, (), session_id))
            case "retx":
                self._retransmit(action[1], action[2])
            case "republish":
                interval = self.config.property_interval
                assert interval is not None
                if self._own:
                    self._dirty = {}
                    self._publish(self._own)
                self._push_timer(self.now + interval, ("republish",))
            case "liveness":
                self._check_liveness()
            case "tombstone":
                tomb = self._tombstones.get(action[1])
                if tomb is not None and tomb[1] <= self.now:
                    del self._tombstones[action[1]]

    def _check_liveness(self) -> None:
        timeout = self.config.effective_failure_timeout
        assert timeout is not None
        cutoff = self.now - timeout
        for node in sorted(n for n, heard in self._heard.items() if heard <= cutoff):
            self._depart(node, reason="failed")
        self._push_timer(self.now + timeout / 3, ("liveness",))

    # ------------------------------------------------------------------ leaving, introspection

    def leave(self, now: float) -> None:
        """Leave on purpose: stop our sessions, drop our roles, tell every peer."""
        self.now = now
        for session in list(self._sessions.values()):
            if not session.stopped:
                self.stop_session(session.sid)
        for part in list(self._participations.values()):
            self._end_participation(part)
        self._emit(Broadcast(codec.encode(Leave()), "leave"))

    def sessions(self) -> list[SessionInfo]:
        """Live sessions started on this node, oldest first."""
        infos = []
        for session in self._sessions.values():
            if session.stopped:
                continue
            definition = session.definition
            described = (
                definition.to_json()
                if isinstance(definition, GroupDefinition)
                else repr(definition)
            )
            members = frozenset(n for n, m in session.members.items() if m.state == _MEMBER)
            pending = frozenset(n for n, m in session.members.items() if m.state == _PENDING)
            infos.append(
                SessionInfo(
                    session.sid,
                    self.node_id,
                    type(session.role).__name__,
                    session.participant_role,
                    members,
                    pending,
                    session.started_at,
                    described,
                )
            )
        return infos

    def session_role(self, sid: str) -> Initiator | None:
        """The initiator role of a live session of this node, if any."""
        session = self._session_by_id(sid)
        return None if session is None or session.stopped else session.role

    def participations(self) -> list[ParticipationInfo]:
        """Participant roles active on this node."""
        return [
            ParticipationInfo(p.ref.session_id, p.initiator, p.role_name, p.since)
            for p in self._participations.values()
            if p.role is not None
        ]

    def state_counts(self) -> dict[str, int]:
        """Sizes of every per-session structure, to check that nothing is left behind."""
        return {
            "sessions": len(self._sessions),
            "members": sum(len(s.members) for s in self._sessions.values()),
            "closing_channels": sum(len(s.closing) for s in self._sessions.values()),
            "participations": len(self._participations),
            "tombstones": len(self._tombstones),
            "role_timers": sum(len(t) for t in self._role_timers.values()),
        }

    def _emit(self, output: Output) -> None:
        self._outbox.append(output)

    def record_sent(self, kind: str, frames: int, size: int) -> None:
        """Count ``frames`` frames of ``size`` bytes each that the transport put on the wire."""
        tally = self.sent_by_kind.setdefault(kind, [0, 0])
        tally[0] += frames
        tally[1] += frames * size

    def _count(self, name: str) -> None:
        self.counters[name] = self.counters.get(name, 0) + 1


_MISSING = object()


def _discard(items: list[Any], item: Any) -> None:
    if item in items:
        items.remove(item)


def _deactivated(role: Participant, ref: InitiatorRef) -> None:
    """Tell a participant it is deactivated (its ``send`` returns False from now on)."""
    role.out_group_of(ref)


def _owner_session(owner: Any) -> str:
    if owner is None:
        return ""
    if owner[0] == "p":
        initiator, session, _ = owner[1]
        return session_id_for(initiator, session)
    return str(owner[1])


def _message_kind(message: Message) -> str:
    match message:
        case PropertyUpdate():
            return "property"
        case ChannelData():
            return "channel"
        case ChannelAck():
            return "ack"
        case Leave():
            return "leave"
