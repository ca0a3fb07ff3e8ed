"""``RoleActivator``: the application's access point to one ObjectPlaces node.

It is the same object on every runtime; the runtime hands it a clock and a ``wake``
function that makes sure the machine's outputs get drained soon after a call (in the
same instant, so updates made together are coalesced into one message).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from mypy_extensions import mypyc_attr

from objectplaces.core.config import ParticipationInfo, SessionInfo
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.events import TimerHandle
from objectplaces.core.groups import DefinitionLike, checked_definition
from objectplaces.core.node import NodeMachine
from objectplaces.core.roles import Initiator, Participant
from tuplespace import TupleSpace

__all__ = ["NodeStats", "ObserverHandle", "RoleActivator", "Session"]


@dataclass(frozen=True, slots=True)
class Session:
    """A running interaction session, as returned by ``start_interaction``."""

    session_id: str
    role: Initiator


@dataclass(frozen=True, slots=True)
class ObserverHandle:
    """A registered observer; ``cancel()`` unregisters it."""

    cancel: Callable[[], None]


@dataclass(frozen=True, slots=True)
class NodeStats:
    """What one node sent and received, by kind, and what it dropped and why.

    Attributes:
        sent: kind -> (frames, bytes) put on the wire.
        received: kind -> (frames, bytes) received.
        counters: what was dropped, retransmitted, broken ... and how often.
        dropped_by_peer: frames refused per peer (malformed or with unusable values).
    """

    sent: dict[str, tuple[int, int]]
    received: dict[str, tuple[int, int]]
    counters: dict[str, int]
    dropped_by_peer: dict[str, int] = field(default_factory=dict)

    @property
    def messages_sent(self) -> int:
        """Frames this node sent."""
        return sum(v[0] for v in self.sent.values())

    @property
    def bytes_sent(self) -> int:
        """Bytes this node sent."""
        return sum(v[1] for v in self.sent.values())

    @property
    def messages_received(self) -> int:
        """Frames this node received."""
        return sum(v[0] for v in self.received.values())

    @property
    def bytes_received(self) -> int:
        """Bytes this node received."""
        return sum(v[1] for v in self.received.values())


@mypyc_attr(allow_interpreted_subclasses=True)
class RoleActivator:
    """Start and stop sessions, publish properties, register participant roles.

    Made by the runtime: ``SimulatedNetwork.add_node`` or ``start_node``.

    Args:
        machine: the node's machine.
        clock: the runtime's clock (virtual or real seconds).
        wake: asks the runtime to drain the machine soon (idempotent).
        space: the node's tuplespace (``space``).
    """

    def __init__(
        self,
        machine: NodeMachine,
        *,
        clock: Callable[[], float],
        wake: Callable[[], None],
        space: TupleSpace,
    ) -> None:
        self._machine = machine
        self._clock = clock
        self._wake = wake
        machine.driver.clock = clock
        machine.driver.wake = wake
        self._space = space

    @property
    def space(self) -> TupleSpace:
        """The node's tuplespace (Linda: ``out``, ``rd``, ``in_``, ``rdp``, ``inp`` ...),
        shared by the application's components on this node and every role it plays
        (a role's ``space`` is this same object). Local to the node: nothing in it is
        sent anywhere."""
        return self._space

    @property
    def node_id(self) -> str:
        """This node's id."""
        return self._machine.node_id

    @property
    def machine(self) -> NodeMachine:
        """The node's sans-I/O machine (for runtimes and introspection)."""
        return self._machine

    def now(self) -> float:
        """The runtime's clock, in seconds: virtual time in the simulation, the event
        loop's monotonic clock on a real network (not the time of day)."""
        return self._clock()

    def update_node_property(self, name: str, value: Any) -> None:
        """Set one of this node's properties and publish it (same-instant updates coalesce).

        Raises:
            NotPlainDataError: a value that is not plain data (a ``TypeError``).
            InvalidValueError: a bad name, a position that is not two finite numbers, a
                hull length that is not a finite number >= 0, a value nested too deep or
                too large (a ``ValueError``). Nothing is published then.
        """
        self._machine.update_property(name, value, self._clock())
        self._wake()

    def set_at_rest(self, at_rest: bool) -> None:
        """Say whether this node is at rest (standing still with nothing to publish): it
        then beats less often, if its configuration has a ``rest_beat_interval``
        (``NodeMachine.set_at_rest``)."""
        self._machine.set_at_rest(at_rest, self._clock())
        self._wake()

    def register_node_property_observer(
        self, observer: Callable[[str, str, Any], Any], *, names: Iterable[str] | None = None
    ) -> ObserverHandle:
        """Call ``observer(node_id, name, value)`` on every property change, ours included;
        given ``names``, only on changes of those properties (others cost nothing).

        Raises:
            TypeError: ``names`` is a single string.
        """
        return ObserverHandle(self._machine.observers.add_property(observer, names))

    def register_node_departure_observer(
        self, observer: Callable[[str, Mapping[str, Any]], Any]
    ) -> ObserverHandle:
        """Call ``observer(node_id, last_properties)`` when a node fails or leaves."""
        return ObserverHandle(self._machine.observers.add_departure(observer))

    def set_participant_factory(self, name: str, factory: Callable[[], Participant] | None) -> None:
        """Register the zero-argument factory of participant role ``name`` (None removes it)."""
        self._machine.set_factory(name, factory)

    def start_interaction(
        self, initiator: Initiator, definition: DefinitionLike, participant_role: str
    ) -> Session:
        """Start a session: activate ``participant_role`` on every node matching ``definition``.

        Args:
            initiator: the initiator role (a fresh ``Initiator``, in no other session).
            definition: who takes part: a callable ``(initiator_props,
                participant_props) -> bool`` or a declarative one (``objectplaces.groups``).
            participant_role: the name of the participant role, as registered on the
                participants' nodes with ``set_participant_factory``.

        Returns:
            The session; ``stop_interaction(session)`` ends it.

        Raises:
            LocalProtocolError: a bad argument, ``initiator`` already in a session, or a
                definition that cannot resolve a group. Nothing is left behind then: no
                session, no activation, the role unbound.
        """
        sid = self._machine.start_session(initiator, definition, participant_role, self._clock())
        self._wake()
        return Session(sid, initiator)

    def stop_interaction(self, session: Session | str) -> None:
        """Stop a session started on this node; every participant is deactivated.

        Raises:
            LocalProtocolError: no live session of this node has that id.
        """
        sid = session.session_id if isinstance(session, Session) else session
        self._machine.stop_session(sid, self._clock())
        self._wake()

    def view_group(self, definition: DefinitionLike) -> frozenset[str]:
        """The nodes that satisfy ``definition`` now, from the local view (no messages).

        Raises:
            LocalProtocolError: ``definition`` is not callable, or cannot resolve a group.
        """
        checked = checked_definition(definition, self._machine.properties)
        return self._machine.view_group(checked)

    def call_later(self, delay: float, fn: Callable[[], Any]) -> TimerHandle:
        """Run ``fn`` after ``delay`` seconds of the runtime's clock (``now()``).

        Returns:
            A handle whose ``cancel()`` stops ``fn`` from running.

        Raises:
            LocalProtocolError: ``delay`` is negative or not a number.
        """
        handle = self._machine.call_later(delay, fn, self._clock())
        self._wake()
        return handle

    @property
    def properties(self) -> Mapping[str, Any]:
        """This node's own properties."""
        return self._machine.properties

    def view(self) -> Mapping[str, Mapping[str, Any]]:
        """The latest known properties of the other nodes this node hears."""
        return self._machine.view()

    def set_property_check(self, check: Callable[[str, str, Any, float], bool] | None) -> None:
        """Check every changed property value a peer publishes before the view takes it.

        ``check(node_id, name, value, now)`` returns False for a value that cannot be
        true (a position further than the peer could have moved since, a size beyond
        any vehicle's): the view keeps the value before, and the refusal is counted per
        peer (``stats().dropped_by_peer``, counter ``refused_implausible``) and logged.
        A check that raises lets the value through (counted: ``property_check_errors``).
        None removes the check.
        """
        self._machine.set_property_check(check)

    def sessions(self) -> list[SessionInfo]:
        """Live sessions initiated on this node."""
        return self._machine.sessions()

    def session_role(self, session_id: str) -> Initiator:
        """The initiator role of a live session of this node.

        Raises:
            LocalProtocolError: no live session of this node has that id.
        """
        role = self._machine.session_role(session_id)
        if role is None:
            raise LocalProtocolError(f"unknown session {session_id!r} on node {self.node_id!r}")
        return role

    def participations(self) -> list[ParticipationInfo]:
        """Participant roles active on this node."""
        return self._machine.participations()

    @property
    def participant_roles(self) -> list[str]:
        """Names of the participant roles this node can play."""
        return sorted(self._machine.factories)

    def stats(self) -> NodeStats:
        """Traffic and drop counters of this node."""
        machine = self._machine
        return NodeStats(
            {k: (v[0], v[1]) for k, v in sorted(machine.sent_by_kind.items())},
            {k: (v[0], v[1]) for k, v in sorted(machine.received_by_kind.items())},
            dict(sorted(machine.counters.items())),
            dict(sorted(machine.dropped_by_peer.items())),
        )

    def __repr__(self) -> str:
        return f"<RoleActivator {self.node_id!r}>"
