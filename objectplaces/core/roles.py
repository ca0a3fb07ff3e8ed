"""The role base classes application code subclasses: ``Initiator`` and ``Participant``.

Callbacks (``in_group``, ``receive`` ...) are plain methods called by the middleware, one
at a time, never concurrently; they must not block. A role gets its context when the
middleware activates it; before that, ``send`` and friends raise ``LocalProtocolError``.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Set
from typing import Any, Protocol

from mypy_extensions import mypyc_attr

from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.events import TimerHandle
from objectplaces.core.ids import InitiatorRef, ParticipantRef

__all__ = [
    "Initiator",
    "InitiatorBinding",
    "OutReason",
    "Participant",
    "ParticipantBinding",
    "Role",
    "bind",
    "is_bound",
]


class OutReason(enum.Enum):
    """Why a participant role was deactivated (``Participant.out_reason``)."""

    STOPPED = "stopped"
    """The initiator stopped the session (or its node left the network)."""
    LEFT_GROUP = "left_group"
    """This node no longer satisfies the session's group definition."""
    RELEASED = "released"
    """The initiator released this participant (``Initiator.release``)."""
    UNREACHABLE = "unreachable"
    """The initiator failed or could not be reached (or took this node for failed)."""
    NODE_LEFT = "node_left"
    """This node left the network."""


class _Binding(Protocol):
    node_id: str
    session_id: str
    space: Any

    def now(self) -> float: ...

    def call_later(self, delay: float, fn: Callable[[], Any]) -> TimerHandle: ...


class InitiatorBinding(_Binding, Protocol):
    """What the middleware gives an initiator role (internal)."""

    def send(self, participant: ParticipantRef, message: Any) -> bool: ...

    def members(self) -> Set[ParticipantRef]: ...

    def release(self, participant: ParticipantRef) -> bool: ...

    def stop(self) -> None: ...


class ParticipantBinding(_Binding, Protocol):
    """What the middleware gives a participant role (internal)."""

    initiator: InitiatorRef

    def send(self, message: Any) -> bool: ...


def bind(role: Role, binding: InitiatorBinding | ParticipantBinding) -> None:
    """Give ``role`` its context in a session (the middleware's side of activation)."""
    role._binding = binding


def is_bound(role: Role) -> bool:
    """Whether ``role`` already plays in a session."""
    return role._binding is not None


@mypyc_attr(allow_interpreted_subclasses=True)
class Role:
    """What every role can do: know where it runs, read the clock, set timers."""

    _binding: Any = None

    def _bound(self) -> Any:
        if self._binding is None:
            raise LocalProtocolError(f"{type(self).__name__} is not active in any session")
        return self._binding

    @property
    def node_id(self) -> str:
        """The id of the node this role runs on."""
        return self._bound().node_id  # type: ignore[no-any-return]

    @property
    def session_id(self) -> str:
        """The id of the session this role plays in."""
        return self._bound().session_id  # type: ignore[no-any-return]

    @property
    def space(self) -> Any:
        """The node's tuplespace, shared with the application components."""
        return self._bound().space

    def now(self) -> float:
        """The node's clock, in seconds: virtual time in the simulation; on a real
        network the event loop's monotonic clock (real seconds elapsed, not the time of
        day: use ``time.time()`` for a timestamp)."""
        return self._bound().now()  # type: ignore[no-any-return]

    def call_later(self, delay: float, fn: Callable[[], Any]) -> TimerHandle:
        """Run ``fn`` after ``delay`` seconds of ``now()`` unless the role is deactivated
        first (its session stops, or it leaves the group).

        Returns:
            A handle whose ``cancel()`` stops ``fn`` from running.

        Raises:
            LocalProtocolError: ``delay`` is negative or not a number.
        """
        return self._bound().call_later(delay, fn)  # type: ignore[no-any-return]


@mypyc_attr(allow_interpreted_subclasses=True)
class Initiator(Role):
    """Starts and owns a session; sees all participants. Subclass and override callbacks.

    One object plays in one session, once: start each session with a fresh one."""

    def started(self) -> None:
        """The session started (called once, before any ``in_group``)."""

    def in_group(self, participant: ParticipantRef) -> None:
        """A participant role was activated on ``participant.node_id``."""

    def out_group(self, participant: ParticipantRef) -> None:
        """``participant`` left the group; nothing more will be received from it."""

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        """``participant`` sent ``message`` (only current members ever get here)."""

    def send(self, participant: ParticipantRef, message: Any) -> bool:
        """Send ``message`` to one participant, reliably and in order.

        Returns:
            False, with nothing sent, when ``participant`` is no longer a member or its
            channel's send buffer is full (``NodeConfig.send_buffer`` messages wait
            beyond the window in flight).

        Raises:
            NotPlainDataError: ``message`` is not plain data (a ``TypeError``).
            InvalidValueError: ``message`` would not fit in a frame (a ``ValueError``).
            LocalProtocolError: ``participant`` belongs to another session.
        """
        return self._bound().send(participant, message)  # type: ignore[no-any-return]

    @property
    def members(self) -> Set[ParticipantRef]:
        """The participants currently in the group: a set (a ``MemberSet``) that
        iterates in node-id order, so seeded runs repeat whatever the hash seed."""
        return self._bound().members()  # type: ignore[no-any-return]

    def release(self, participant: ParticipantRef) -> bool:
        """Deactivate one participant, leaving the others in the session.

        Its role hears ``out_group_of`` with ``out_reason`` ``OutReason.RELEASED``; this
        role hears no ``out_group`` for it (it asked). Its node is not activated again
        in this session while it keeps satisfying the definition; once it leaves the
        group and comes back, it is.

        Returns:
            False when ``participant`` is no member (nothing done).

        Raises:
            LocalProtocolError: ``participant`` belongs to another session.
        """
        return self._bound().release(participant)  # type: ignore[no-any-return]

    def stop(self) -> None:
        """Stop the session: every participant is deactivated."""
        self._bound().stop()


@mypyc_attr(allow_interpreted_subclasses=True)
class Participant(Role):
    """Activated by the middleware on nodes that satisfy a group definition."""

    #: Why the role was deactivated; None while it is active.
    out_reason: OutReason | None = None

    def in_group_of(self, initiator: InitiatorRef) -> None:
        """The role was activated in ``initiator``'s session."""

    def out_group_of(self, initiator: InitiatorRef) -> None:
        """The role was deactivated; ``self.out_reason`` says why (``OutReason``: the
        session stopped, this node left the group, the initiator released it or could
        not be reached, or this node left the network)."""

    def receive(self, message: Any) -> None:
        """The initiator sent ``message``."""

    def send(self, message: Any) -> bool:
        """Send ``message`` to the initiator, reliably and in order.

        Returns:
            False, with nothing sent, when the role is no longer active or its channel's
            send buffer is full.

        Raises:
            NotPlainDataError: ``message`` is not plain data (a ``TypeError``).
            InvalidValueError: ``message`` would not fit in a frame (a ``ValueError``).
        """
        return self._bound().send(message)  # type: ignore[no-any-return]

    @property
    def initiator(self) -> InitiatorRef:
        """The initiator of this role's session."""
        return self._bound().initiator  # type: ignore[no-any-return]
