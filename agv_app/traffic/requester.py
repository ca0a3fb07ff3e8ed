"""The requester role (:mod:`agv_app.traffic.collision`): asks the collision group to
allow one hull projection, then locks it."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from agv_app.protocol import MessageTally, tally_send
from agv_app.traffic.collision_groups import group_within
from agv_app.traffic.lockbook import LockBook, RequestEntry
from agv_app.traffic.request_wire import request_message
from objectplaces import Initiator, ParticipantRef
from objectplaces.groups import GroupDefinition

__all__ = ["Requester"]


def _outwaited(since: Mapping[str, float], patience: float | None, now: float) -> bool:
    if patience is None:
        return False
    return any(now - t >= patience - 1e-9 for t in since.values())


class Requester(Initiator):
    """Asks the collision group to allow one hull projection, then locks it.

    Args:
        entry: the request, already recorded in the node's :class:`LockBook`.
        safe_time: seconds to wait at least before locking (``2 * t_update``).
        group_view: the node's current view of the collision group (``view_group``).
        on_done: called once with ``"locked"`` or ``"withdrawn"``.
        patience: seconds a voter's lock may hold the request up before it withdraws
            (None: never; the AGV then steps aside for the lock's owner instead).
        queue_patience: seconds a voter's older request may hold it up before it
            withdraws (None: never).
        tally: counts the messages sent.
        announced_at: when a circle that covers the area was published, if that was
            before the session starts and every circle published since covered the area
            too (an AGV asks again for no more than before): the safe time counts from
            then, as the others have had such a circle since (docs/traffic.md, "Asking
            again").
        definition: the group definition the session was opened with; a request asked
            again whose group lies within it may be asked on this session
            (:meth:`ask_again`).
        vote_deadline: seconds a member may take to answer at all (every voter answers
            at once, allow or defer); one silent that long is counted as failed: its
            vote is no longer awaited and ``on_silent`` is told (None: wait for ever).
        on_silent: told the id of a member counted as failed
            (:meth:`~agv_app.traffic.plausibility.PeerWatch.silent`).
        on_outwaited: called instead of withdrawing when an older request has held
            this one up for ``queue_patience``: the AGV asks again at once, at the same
            age (:meth:`withdraw` with the session kept, then :meth:`ask_again`), so its
            voter never stands without a request for a younger one to slip past.
    """

    def __init__(
        self,
        entry: RequestEntry,
        *,
        safe_time: float,
        patience: float | None = 4.0,
        queue_patience: float | None = None,
        group_view: Callable[[], frozenset[str]],
        on_done: Callable[[str], None],
        tally: MessageTally | None = None,
        announced_at: float | None = None,
        definition: GroupDefinition | None = None,
        vote_deadline: float | None = None,
        on_silent: Callable[[str], None] | None = None,
        on_outwaited: Callable[[], None] | None = None,
    ) -> None:
        self.entry = entry
        self._on_outwaited = on_outwaited
        self.vote_deadline = vote_deadline
        self._on_silent = on_silent
        self._asked: dict[str, float] = {}  # member -> when it was asked
        self._answered: set[str] = set()  # members that answered the current request
        self._silent: set[str] = set()  # members counted as failed
        self._definition = definition
        self._kept = False  # withdrawn with the session kept open for the next request
        self.safe_time = safe_time
        self._announced_at = announced_at
        self._group_view = group_view
        self._on_done = on_done
        self._tally = tally
        self.patience = patience
        self.queue_patience = queue_patience
        self._queued: dict[str, float] = {}
        self._votes: dict[str, bool] = {}
        self._blocked: dict[str, float] = {}
        self._message = request_message(entry)
        self._started_at: float | None = None
        self._safe_from = 0.0
        self.done = ""
        """``""`` while pending, then ``"locked"`` or ``"withdrawn"``."""

    @property
    def blocked_by(self) -> frozenset[str]:
        """The members that deferred because of one of their locks (their AGV stands or
        drives in the requested area)."""
        return frozenset(self._blocked)

    @property
    def votes(self) -> Mapping[str, bool]:
        """Current members by node id, and whether each allowed."""
        return self._votes

    def started(self) -> None:
        """Remember the start time and check again once the safe time has passed."""
        now = self.now()
        self._started_at = now
        announced = self._announced_at
        self._safe_from = now if announced is None else min(now, announced)
        self.call_later(max(0.0, self._safe_from + self.safe_time - now), self._check)

    def in_group(self, participant: ParticipantRef) -> None:
        """A new member (late joiners too) gets the request; the lock waits for its vote."""
        self._votes[participant.node_id] = False
        self._asked_now(participant.node_id)
        self.send(participant, self._message)
        tally_send(self._tally, "request", self._message)

    def _asked_now(self, node: str) -> None:
        self._asked[node] = self.now()
        if self.vote_deadline is not None:
            self.call_later(self.vote_deadline, self._check)

    def out_group(self, participant: ParticipantRef) -> None:
        """A member left: its vote no longer counts.

        The check runs after the events of this instant, so that a departure's stale
        record is written before the requester decides.
        """
        node = participant.node_id
        self._votes.pop(node, None)
        self._blocked.pop(node, None)
        self._queued.pop(node, None)
        self._asked.pop(node, None)
        self._answered.discard(node)
        self._silent.discard(node)
        self.call_later(0.0, self._check)

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        """A vote: ``allow`` counts; a deferral because of a lock withdraws the request.
        ``revoke``: the member takes its allow back; it counts no more, and the member
        hears that it does not (``revoked``) before it ranks its own requests higher.

        A vote on an earlier request of this session (asked again since) is ignored, and
        so is a revoke once the request is locked or withdrawn (its ``end``, or the next
        request, tells the member).
        """
        if not isinstance(message, dict) or self.done:
            return
        if message.get("k", self.entry.key) != self.entry.key:
            return
        node = participant.node_id
        if message.get("t") == "revoke":
            if self._votes.get(node):
                self._votes[node] = False
            reply: dict[str, Any] = {"t": "revoked", "k": self.entry.key}
            if self.send(participant, reply):
                tally_send(self._tally, "vote", reply)
            return
        if message.get("t") in ("allow", "defer"):
            self._answered.add(node)
            if node in self._silent:  # it was only late: its vote counts again
                self._silent.discard(node)
                self._votes[node] = False
        if message.get("t") == "allow":
            self._votes[node] = True
            self._blocked.pop(node, None)
            self._queued.pop(node, None)
            self._check()
        elif message.get("t") == "defer":
            why = message.get("why")
            self._track(self._blocked, node, why == "lock", self.patience)
            self._track(self._queued, node, why == "priority", self.queue_patience)

    def _track(
        self, since: dict[str, float], node: str, held: bool, patience: float | None
    ) -> None:
        if not held:
            since.pop(node, None)
        elif node not in since:
            since[node] = self.now()
            if patience is not None:
                self.call_later(patience, self._check)

    def check(self) -> None:
        """Re-check whether the lock can be taken (the driver calls it periodically)."""
        self._check()

    def withdraw(self, *, keep_session: bool = False) -> None:
        """Drop the request now (the AGV steps aside, or asks again with a new priority).

        With ``keep_session`` the session stays open, its members and channels kept,
        for the request asked next (:meth:`ask_again`; :meth:`close` if there is none).
        """
        if not self.done and self._started_at is not None:
            self._kept = keep_session
            self._finish("withdrawn", end_session=not keep_session)

    def ask_again(
        self, entry: RequestEntry, definition: GroupDefinition, *, announced_at: float | None
    ) -> bool:
        """Ask the members of the kept session for ``entry`` instead of the withdrawn
        request; False (nothing done) if the session was not kept or ``definition``,
        the new request's group, does not lie within the session's.

        Every member gets the new request at once; to its voter it is a new request
        (verdict, records, the end of the one before: ``Voter.receive``). The votes
        start again, and so does the safe time, from now or ``announced_at``, as in a
        session opened now.
        """
        old = self._definition
        if not self._kept or old is None or not group_within(definition, old):
            return False
        self._kept = False
        self.done = ""
        self.entry = entry
        self._message = request_message(entry)
        self._announced_at = announced_at
        self._votes = dict.fromkeys(sorted([*self._votes, *self._silent]), False)
        self._blocked.clear()
        self._queued.clear()
        self._answered.clear()
        self._silent.clear()
        self.started()
        for member in sorted(self.members, key=lambda m: m.node_id):  # never set order
            if member.node_id in self._votes:
                self._asked_now(member.node_id)
                self.send(member, self._message)
                tally_send(self._tally, "request", self._message)
        return True

    def close(self) -> None:
        """End a kept session that no request was asked on (:meth:`withdraw`)."""
        if self._kept:
            self._kept = False
            self._end_session()

    def _check(self) -> None:
        if self.done or self._started_at is None:
            return
        book = LockBook(self.space)
        now = self.now()
        if book.hits_stale(self.entry.area) or _outwaited(self._blocked, self.patience, now):
            self._finish("withdrawn")
            return
        if _outwaited(self._queued, self.queue_patience, now):
            if self._on_outwaited is None:
                self._finish("withdrawn")
            else:
                self._queued.clear()
                self._on_outwaited()
            return
        silent = self.vote_deadline is not None and self._count_silent(now)
        if silent and book.hits_stale(self.entry.area):  # a silent member's floor
            self._finish("withdrawn")
            return
        if now - self._safe_from < self.safe_time - 1e-9:
            return
        if not all(self._votes.values()):
            return
        if not self._group_view() - self._silent <= self._votes.keys():
            return  # someone in our view has not joined (or answered) yet
        self._finish("locked")

    def _count_silent(self, now: float) -> bool:
        """Count as failed the members that have not answered within the deadline;
        whether any was."""
        deadline = self.vote_deadline
        assert deadline is not None
        silent = [
            node
            for node in sorted(self._votes)
            if node not in self._answered and now - self._asked.get(node, now) >= deadline - 1e-9
        ]
        for node in silent:
            del self._votes[node]
            self._silent.add(node)
            if self._on_silent is not None:
                self._on_silent(node)
        return bool(silent)

    def _finish(self, outcome: str, *, end_session: bool = True) -> None:
        self.done = outcome
        book = LockBook(self.space)
        if outcome == "locked":
            book.grant(self.entry.key)
        else:
            book.withdraw(self.entry.key)
        if end_session:
            self._end_session()
        self._on_done(outcome)

    def _end_session(self) -> None:
        # Those that allowed need no longer rank below this request (written after the
        # lock, so their next requests meet it as a lock).
        end: dict[str, Any] = {"t": "end"}
        for member in sorted(self.members, key=lambda m: m.node_id):  # never set order
            if self._votes.get(member.node_id) and self.send(member, end):
                tally_send(self._tally, "vote", end)
        self.stop()
