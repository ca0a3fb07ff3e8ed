"""The context a role is bound to while it plays in a session.

Roles are application code; what they may ask of the middleware is exactly the
``InitiatorBinding`` / ``ParticipantBinding`` protocols of roles.py. The contexts here
implement those protocols on the public commands of the two tables (``SessionTable``,
``ParticipationTable``) and of the machine (``RoleHost``: clock and timers), never on
private state: a context names its session (or its participation, epoch included) and
the table decides, so a role whose session ended simply gets False from ``send``.

A role's clock is the driver's (``DriverLink``). Role callbacks run after an input, in
the same instant, so in the simulation every command they issue carries that input's
time. A role may also act from outside a callback (from its own asyncio task or an
application timer): its command then carries the driver's current time, not the last
input's, and wakes the driver so that what it queued is sent now, not with the next
input that happens to arrive.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

from objectplaces.core.events import TimerHandle
from objectplaces.core.ids import InitiatorRef, ParticipantRef, SessionId
from objectplaces.core.members import MemberSet
from objectplaces.core.timers import ParticipationOwner, RoleOwner, SessionOwner

if TYPE_CHECKING:  # the tables bind roles to these contexts: import them for types only
    from objectplaces.core.participations import ParticipationTable
    from objectplaces.core.sessions import SessionTable

__all__ = ["DriverLink", "InitiatorContext", "ParticipantContext", "RoleHost"]


def _no_wake() -> None:
    """The wake of a machine no runtime drives (tests that drain it by hand)."""


class DriverLink:
    """The clock and wake of whoever drives a machine, as role contexts see them.

    The machine's own default reads the time of its latest input and wakes nobody; a
    runtime (``RoleActivator``) sets both to its own.
    """

    __slots__ = ("clock", "wake")

    def __init__(self, clock: Callable[[], float], wake: Callable[[], None] = _no_wake) -> None:
        self.clock = clock
        self.wake = wake


class RoleHost(Protocol):
    """What every role context needs of the node machine (implemented by ``NodeMachine``)."""

    @property
    def node_id(self) -> str:
        """The node's id."""
        ...

    @property
    def space(self) -> Any:
        """The node's tuplespace."""
        ...

    @property
    def driver(self) -> DriverLink:
        """The driver's clock and wake."""
        ...

    def call_later(
        self, delay: float, fn: Callable[[], Any], now: float, *, owner: RoleOwner | None = None
    ) -> TimerHandle:
        """Run ``fn`` at ``now + delay``; cancelled when ``owner`` ends."""
        ...


class InitiatorContext:
    """An initiator role's view of its session (see ``roles.InitiatorBinding``)."""

    __slots__ = ("_host", "_owner", "_sessions", "node_id", "session_id", "space")

    def __init__(self, host: RoleHost, sessions: SessionTable, session_id: SessionId) -> None:
        self._host = host
        self._sessions = sessions
        self._owner = SessionOwner(session_id)
        self.node_id = host.node_id
        self.session_id: str = session_id
        self.space = host.space

    def now(self) -> float:
        """The node's clock."""
        return self._host.driver.clock()

    def call_later(self, delay: float, fn: Callable[[], Any]) -> TimerHandle:
        """A timer that dies with the session."""
        host, driver = self._host, self._host.driver
        handle = host.call_later(delay, fn, driver.clock(), owner=self._owner)
        driver.wake()
        return handle

    def send(self, participant: ParticipantRef, message: Any) -> bool:
        """Send to one member (False when it is none)."""
        driver = self._host.driver
        sent = self._sessions.send(self.session_id, participant, message, driver.clock())
        driver.wake()
        return sent

    def members(self) -> MemberSet:
        """The joined members, in node-id order."""
        return self._sessions.members_of(self.session_id)

    def release(self, participant: ParticipantRef) -> bool:
        """Deactivate one member (False when it is none)."""
        driver = self._host.driver
        released = self._sessions.release(self.session_id, participant, driver.clock())
        driver.wake()
        return released

    def stop(self) -> None:
        """Stop the session."""
        driver = self._host.driver
        self._sessions.stop(self.session_id, driver.clock())
        driver.wake()


class ParticipantContext:
    """A participant role's view of its participation (see ``roles.ParticipantBinding``)."""

    __slots__ = ("_host", "_owner", "_table", "initiator", "node_id", "session_id", "space")

    def __init__(
        self,
        host: RoleHost,
        table: ParticipationTable,
        owner: ParticipationOwner,
        initiator: InitiatorRef,
    ) -> None:
        self._host = host
        self._table = table
        self._owner = owner
        self.node_id = host.node_id
        self.session_id: str = initiator.session_id
        self.space = host.space
        self.initiator = initiator

    def now(self) -> float:
        """The node's clock."""
        return self._host.driver.clock()

    def call_later(self, delay: float, fn: Callable[[], Any]) -> TimerHandle:
        """A timer that dies with this activation."""
        host, driver = self._host, self._host.driver
        handle = host.call_later(delay, fn, driver.clock(), owner=self._owner)
        driver.wake()
        return handle

    def send(self, message: Any) -> bool:
        """Send to the initiator (False once deactivated)."""
        driver = self._host.driver
        sent = self._table.send(self._owner, message, driver.clock())
        driver.wake()
        return sent
