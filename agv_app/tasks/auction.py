"""Task assignment: a station auctions a transport task among idle AGVs in range.

* :class:`TaskAnnouncer` (initiator, run by a station on the transport base's node)
  starts a session with a declarative group (``near(station, range) & status == "idle"``
  among AGVs), sends the task to every member, late joiners included, collects bids
  (route distance to the pick station) for a bidding window, awards the task to the best
  bid (lowest cost, then lowest node id) and stops. Without a bid it keeps waiting; the
  station may restart it with a wider range.
* :class:`Bidder` (participant, on every AGV) bids when its AGV is free. An AGV bids in
  one auction at a time (a ``("bid", session)`` tuple in its space), so an award always
  finds it free: the award is final and a task is never given to two AGVs. A bidder
  that finds its AGV bidding elsewhere tries again every ``retry`` seconds; it sleeps
  through the tries that would find that bid still out and is woken (the space's
  ``notify``) when it ends, for its next try. The tries keep their times, so the
  auctions an AGV moves on to spread as before; an AGV in range of many stations has
  a bidder waiting in each, and most of their tries would have found nothing to do.

A task that an AGV cannot finish (its node fails) is returned by the station, which
watches its winners' departures (see :mod:`agv_app.tasks.station`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from agv_app.protocol import AGV_KIND, MessageTally, tally_send
from objectplaces import Initiator, Participant, ParticipantRef, groups
from objectplaces.groups import GroupDefinition
from tuplespace import ANY, NotifyHandle

__all__ = ["Bidder", "TaskAgent", "TaskAnnouncer", "TaskSpec", "bidder_group"]


@dataclass(frozen=True, slots=True)
class TaskSpec:
    """A transport task: carry a load from ``pick`` to ``drop`` (station ids)."""

    id: str
    pick: str
    drop: str

    def to_message(self) -> dict[str, Any]:
        """Plain-data form for the wire."""
        return {"t": "task", "id": self.id, "pick": self.pick, "drop": self.drop}

    @classmethod
    def from_message(cls, message: Any) -> TaskSpec | None:
        """Parse :meth:`to_message`'s form; None if malformed."""
        if not isinstance(message, dict):
            return None
        fields = (message.get("id"), message.get("pick"), message.get("drop"))
        if not all(isinstance(f, str) for f in fields):
            return None
        return cls(str(fields[0]), str(fields[1]), str(fields[2]))


def bidder_group(range_m: float | None, station: tuple[float, float]) -> GroupDefinition:
    """Idle AGVs within ``range_m`` of the ``station``'s point (anywhere when None)."""
    idle = groups.property_equals("kind", AGV_KIND) & groups.property_equals("status", "idle")
    return idle if range_m is None else groups.near(station, range_m) & idle


class TaskAgent(Protocol):
    """What a bidder needs from its AGV."""

    def bid_for(self, task: TaskSpec) -> float | None:
        """The AGV's cost for ``task`` (route distance), or None if it cannot take it."""
        ...

    def take(self, task: TaskSpec) -> None:
        """Carry out ``task`` (called once, on award)."""
        ...


class TaskAnnouncer(Initiator):
    """Auctions one task among the session's members.

    Args:
        task: the task.
        window: bidding window in seconds from the first bid.
        on_awarded: called with the winner's node id once the award is sent.
        tally: counts the messages sent.
    """

    def __init__(
        self,
        task: TaskSpec,
        *,
        on_awarded: Callable[[TaskSpec, str], None],
        window: float = 1.5,
        tally: MessageTally | None = None,
    ) -> None:
        self.task = task
        self.window = window
        self._on_awarded = on_awarded
        self._tally = tally
        self._bids: dict[str, float] = {}
        self._members: dict[str, ParticipantRef] = {}
        self._closing = False
        self.winner: str | None = None
        """The node the task was awarded to, once it was."""

    @property
    def bids(self) -> dict[str, float]:
        """Bids received from current members, by node id."""
        return dict(self._bids)

    def in_group(self, participant: ParticipantRef) -> None:
        """Tell the newcomer about the task (late joiners may still bid)."""
        self._members[participant.node_id] = participant
        message = self.task.to_message()
        self.send(participant, message)
        tally_send(self._tally, "task", message)

    def out_group(self, participant: ParticipantRef) -> None:
        """A member left (busy, out of range or failed): its bid is void."""
        self._members.pop(participant.node_id, None)
        self._bids.pop(participant.node_id, None)

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        """A bid; the first one opens the bidding window."""
        if self.winner is not None or not isinstance(message, dict):
            return
        if message.get("t") != "bid" or not isinstance(message.get("c"), int | float):
            return
        self._bids[participant.node_id] = float(message["c"])
        if not self._closing:
            self._closing = True
            self.call_later(self.window, self._award)

    def _award(self) -> None:
        self._closing = False
        for node_id, _ in sorted(self._bids.items(), key=lambda kv: (kv[1], kv[0])):
            ref = self._members.get(node_id)
            message = {"t": "award", "id": self.task.id}
            if ref is not None and self.send(ref, message):
                tally_send(self._tally, "award", message)
                self.winner = node_id
                # The award travels before the deactivation on the same FIFO channel.
                self.stop()
                self._on_awarded(self.task, node_id)
                return
        self._bids.clear()


class Bidder(Participant):
    """Bids for its AGV and takes the task when awarded.

    Args:
        agent: the AGV.
        retry: seconds between attempts to bid while the AGV bids elsewhere or cannot
            take the task (busy, until the station hears so and ends this activation).
        tally: counts the messages sent.
    """

    def __init__(
        self, agent: TaskAgent, *, retry: float = 0.5, tally: MessageTally | None = None
    ) -> None:
        self._agent = agent
        self._retry = retry
        self._tally = tally
        self._task: TaskSpec | None = None
        self._bid = False
        self._active = False
        self._waiting = False  # for the AGV's bid elsewhere to end
        self._next_try = 0.0  # when a try finding that bid still out was due
        self._bids_ending: NotifyHandle | None = None

    def in_group_of(self, initiator: Any) -> None:
        """Activated for a station's auction."""
        self._active = True
        self._bids_ending = self.space.notify(("bid", ANY), self._bid_ended, on="in")

    def out_group_of(self, initiator: Any) -> None:
        """The auction ended for us: we may bid elsewhere again."""
        self._active = False
        if self._bids_ending is not None:
            self._bids_ending.cancel()
            self._bids_ending = None
        if self._bid:
            self.space.inp(("bid", self.session_id))
            self._bid = False

    def receive(self, message: Any) -> None:
        """The announcement (bid on it) or the award (take the task)."""
        if not isinstance(message, dict):
            return
        if message.get("t") == "task":
            self._task = TaskSpec.from_message(message)
            self._try_bid()
        elif message.get("t") == "award" and self._bid and self._task is not None:
            task = self._task
            self._task = None
            self._agent.take(task)

    def _try_bid(self) -> None:
        if not self._active or self._bid or self._task is None:
            return
        space = self.space
        if space.rdp(("bid", ANY)) is not None:
            self._waiting = True  # until ``_bid_ended``
            self._next_try = self.now() + self._retry
            return
        cost = self._agent.bid_for(self._task)
        if cost is None:
            self.call_later(self._retry, self._try_bid)
            return
        space.out(("bid", self.session_id))
        self._bid = True
        message = {"t": "bid", "c": round(cost, 2)}
        self.send(message)
        tally_send(self._tally, "bid", message)

    def _bid_ended(self, kind: str, tup: Any) -> None:
        """The AGV's bid in another auction ended: try again at the first try's time
        after now, as a callback of our own (this runs inside the role that took the
        tuple)."""
        if not (self._waiting and self._active):
            return
        self._waiting = False
        now, due = self.now(), self._next_try
        while due <= now:  # the tries slept through, each one ``retry`` after the last
            due += self._retry
        self.call_later(due - now, self._try_bid)
