"""The machine's timers: what can be due, a queue ordered by deadline, and role timers.

A sans-I/O machine cannot sleep; it says when it next needs ``tick(now)``
(``next_deadline()``) and the driver calls it then, or later. So every timer is an
entry in one heap, and what the entry *means* is a small immutable value (a
``TimerAction``) that the machine matches exhaustively when it fires: a new kind of
timer that nobody handles fails the type check (``assert_never``) instead of being
silently ignored, which is what untyped tuples used to allow. The two made most often
(per channel frame sent, per role timer) are immutable by convention rather than
frozen dataclasses, whose fields are set at three times the cost.

Entries are never removed from the middle of the heap: a cancelled role timer or the
retransmission timer of a closed channel stays until it reaches the top, where the
machine asks whether it is dead and drops it. That keeps cancelling O(1); to keep
memory bounded when many timers are cancelled far ahead of their deadline, the queue
rebuilds itself without the dead entries whenever it has doubled since the last
rebuild (``compact``).

Ties fire in the order they were scheduled (a sequence number breaks them), so a run
is reproducible whatever the heap does internally (STYLE.md §7).
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeAlias

from objectplaces.core.channel import Channel
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.events import TimerHandle
from objectplaces.core.ids import SessionId, session_id_for

__all__ = [
    "CheckLiveness",
    "ExpireTombstone",
    "ParticipationOwner",
    "RepeatLeft",
    "Republish",
    "Retransmit",
    "RoleOwner",
    "RoleTimers",
    "RunTimer",
    "SendBeat",
    "SessionOwner",
    "TimerAction",
    "TimerQueue",
    "is_dead",
]


@dataclass(slots=True, eq=False)
class Retransmit:
    """Retransmit what is due on ``channel``: the one timer the channel has armed for
    ``at`` (an earlier one replaces it when a new frame is due sooner)."""

    target: str
    channel: Channel
    at: float


@dataclass(frozen=True, slots=True)
class Republish:
    """Republish every own property, then again after ``every``: the heartbeat (§2)."""

    every: float


@dataclass(frozen=True, slots=True)
class SendBeat:
    """Send a liveness beat if nothing was published for ``every``; look again when the
    node will next have been silent that long (§2)."""

    every: float


@dataclass(frozen=True, slots=True)
class CheckLiveness:
    """Declare failed every node not heard for ``timeout``; check again after a third of
    it, so a failure is noticed within 4/3 of the timeout (docs/protocol.md §2)."""

    timeout: float


@dataclass(frozen=True, slots=True)
class ExpireTombstone:
    """Forget the closed channel of (initiator, session) if its tombstone has expired."""

    initiator: str
    session: int


@dataclass(frozen=True, slots=True)
class RepeatLeft:
    """Send the ``LEFT`` of channel (initiator, session, epoch) again if it is still
    unacknowledged."""

    initiator: str
    session: int
    epoch: int


@dataclass(slots=True, eq=False)
class RunTimer:
    """Run a ``call_later`` callback (a role's or the application's)."""

    handle: TimerHandle


TimerAction: TypeAlias = (
    Retransmit | Republish | SendBeat | CheckLiveness | ExpireTombstone | RepeatLeft | RunTimer
)


@dataclass(frozen=True, slots=True)
class SessionOwner:
    """Timers of an initiator role: cancelled when its session stops."""

    session_id: SessionId


@dataclass(frozen=True, slots=True)
class ParticipationOwner:
    """Timers of a participant role: cancelled when that activation ends.

    The epoch is part of the key because a node that leaves a group and rejoins gets a
    new role; the old role's timers must not outlive it.
    """

    initiator: str
    session: int
    epoch: int

    @property
    def session_id(self) -> SessionId:
        """The network-wide id of the session."""
        return session_id_for(self.initiator, self.session)


RoleOwner: TypeAlias = SessionOwner | ParticipationOwner


def is_dead(action: TimerAction) -> bool:
    """Whether ``action`` no longer needs to fire: a cancelled role timer, or the
    retransmission timer of a channel its owner has closed."""
    # Type checks, not a match: the driver asks this after every drain.
    kind = type(action)
    if kind is Retransmit:
        channel = action.channel  # type: ignore[union-attr]
        return channel.closed or channel.armed_at != action.at  # type: ignore[union-attr]
    if kind is RunTimer:
        return action.handle.cancelled  # type: ignore[union-attr]
    return False


_COMPACT_FLOOR = 1024  # below this many entries the heap is never worth compacting


class TimerQueue:
    """Timer actions ordered by deadline; dead entries (``is_dead``) are dropped lazily."""

    __slots__ = ("_compact_at", "_heap", "_seq", "changed")

    def __init__(self) -> None:
        self._heap: list[tuple[float, int, TimerAction]] = []
        self._seq = itertools.count()
        self._compact_at = _COMPACT_FLOOR
        #: Set whenever the earliest deadline may have moved; the driver must re-read it.
        self.changed = False

    def __len__(self) -> int:
        return len(self._heap)

    def push(self, deadline: float, action: TimerAction) -> None:
        """Schedule ``action`` at ``deadline``."""
        heap = self._heap
        heapq.heappush(heap, (deadline, next(self._seq), action))
        self.changed = True
        if len(heap) >= self._compact_at:
            self.compact()

    def pop_due(self, now: float) -> TimerAction | None:
        """Remove and return the earliest action due at ``now``, or None."""
        heap = self._heap
        if heap and heap[0][0] <= now:
            self.changed = True
            return heapq.heappop(heap)[2]
        return None

    def next_deadline(self) -> float | None:
        """The earliest deadline of a live action (dead ones on top are dropped)."""
        heap = self._heap
        while heap and is_dead(heap[0][2]):
            heapq.heappop(heap)
        return heap[0][0] if heap else None

    def compact(self) -> None:
        """Drop every dead entry now.

        O(n), run when the heap has doubled since the last run, so amortised O(1) per
        push, and the heap never holds more than about twice its live entries.
        """
        self._heap = [entry for entry in self._heap if not is_dead(entry[2])]
        heapq.heapify(self._heap)
        self._compact_at = max(_COMPACT_FLOOR, 2 * len(self._heap))


class RoleTimers:
    """``call_later`` timers, and which role owns each, so they die with the role.

    Args:
        queue: the machine's timer queue, where each timer becomes a ``RunTimer``.
    """

    __slots__ = ("_by_owner", "_queue")

    def __init__(self, queue: TimerQueue) -> None:
        self._queue = queue
        self._by_owner: dict[RoleOwner, set[TimerHandle]] = {}

    def __len__(self) -> int:
        return sum(len(handles) for handles in self._by_owner.values())

    def schedule(
        self, now: float, delay: float, fn: Callable[[], Any], owner: RoleOwner | None
    ) -> TimerHandle:
        """Run ``fn`` at ``now + delay`` unless ``owner`` (None: nobody) ends first.

        Raises:
            LocalProtocolError: ``delay`` is negative or not a number.
        """
        if not delay >= 0:
            raise LocalProtocolError(f"delay must be >= 0 seconds, got {delay!r}")
        deadline = now + delay
        handle = TimerHandle(deadline, fn, owner)
        if owner is not None:
            self._by_owner.setdefault(owner, set()).add(handle)
        self._queue.push(deadline, RunTimer(handle))
        return handle

    def cancel(self, owner: RoleOwner) -> None:
        """Cancel every pending timer of ``owner``."""
        for handle in self._by_owner.pop(owner, ()):
            handle.cancelled = True

    def fire(self, handle: TimerHandle) -> bool:
        """``handle`` is due: forget it; whether its callback should run (not cancelled)."""
        if handle.cancelled:
            return False
        handle.cancelled = True  # a cancel() after it ran changes nothing
        handles = self._by_owner.get(handle.owner)
        if handles is not None:
            handles.discard(handle)
            if not handles:
                del self._by_owner[handle.owner]
        return True
