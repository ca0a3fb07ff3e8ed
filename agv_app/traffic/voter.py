"""The voter role (:mod:`agv_app.traffic.collision`): votes on other AGVs' requests for
this node's AGV."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from agv_app.geometry import Area
from agv_app.geometry.probe import Probe
from agv_app.protocol import MessageTally, tally_send
from agv_app.traffic.deadlock import Claim
from agv_app.traffic.fifo import AGE_FIELD
from agv_app.traffic.lockbook import LockBook, Priority
from agv_app.traffic.request_wire import received_request
from agv_app.traffic.vote import decide_vote
from objectplaces import Participant
from tuplespace import ANY, NotifyHandle, TupleSpace

__all__ = ["Voter"]


class Voter(Participant):
    """Votes on other AGVs' requests for this node's AGV.

    Args:
        view: the node's view of the others' properties (``RoleActivator.view``): where
            the requester's circle is read.
        recheck: seconds between re-evaluations of a deferred request.
        keep_allowed: seconds an allowed request still lowers this node's own priorities
            once this node left its session (while in it: until the request ends).
        blockers: the nodes whose locks hold up this node's own pending request.
        step_aside: withdraws this node's pending request and asks again at once (its
            new priority ranks below the request just allowed).
        revoked: told when an allow this voter took back (this node's AGV asked for it
            with ``LockBook.revoke``) counts no more: the AGV may ask again higher.
        tally: counts the messages sent.
    """

    def __init__(
        self,
        *,
        view: Callable[[], Mapping[str, Mapping[str, Any]]],
        recheck: float = 0.5,
        keep_allowed: float = 30.0,
        blockers: Callable[[], frozenset[str]] | None = None,
        step_aside: Callable[[], None] | None = None,
        revoked: Callable[[], None] | None = None,
        tally: MessageTally | None = None,
    ) -> None:
        self._blockers = blockers
        self._step_aside = step_aside
        self._revoked = revoked
        self._revoking = False  # a revoke of the current allow is on its way
        self._view = view
        self._keep = keep_allowed
        self._recheck = recheck
        self._tally = tally
        self._area: Area | None = None
        self._probe: Probe | None = None
        self._claims: frozenset[Claim] = frozenset()
        self._priority: Priority = (0.0, "")
        self._age = 0.0  # the age of the wait the request serves (agv_app.traffic.fifo)
        self._said = ""
        # What the last vote was decided on (the book's version and the requester's
        # circle) and its verdict: the same inputs give the same verdict.
        self._decided: tuple[Any, str] | None = None
        self._watches: list[NotifyHandle] = []
        self._active = False
        # The request voted on (its key) and the name of this node's records of it: a
        # session may ask again (``Requester.ask_again``), and each request is new.
        self._key: Any = None
        self._record = ""
        self._round = 0  # bumped at each new request: the rechecks of the last one stop

    @property
    def verdict(self) -> str:
        """What this voter last said: ``""`` (nothing yet), ``"allow"`` or a reason."""
        return self._said

    def in_group_of(self, initiator: Any) -> None:
        """Start watching this node's locks and request for releases."""
        self._active = True

    def out_group_of(self, initiator: Any) -> None:
        """The session ended or this node left the group: stop watching; remember an
        allow for ``keep_allowed`` more (its requester may not have heard yet)."""
        self._active = False
        self._unwatch()
        if self._said == "allow":
            LockBook(self.space).keep_allowed(self._record, self._keep)

    def _unwatch(self) -> None:
        for handle in self._watches:
            handle.cancel()
        self._watches = []

    def receive(self, message: Any) -> None:
        """The request: evaluate it at once. Its end: forget that we allowed it.

        A request with another key on the same session (asked again) is a new request:
        the one before it ended (as with ``end``), and the verdict, the watches, the
        rechecks and the records start afresh, as in a new session.
        """
        if isinstance(message, dict) and message.get("t") == "end":
            # The request is locked (the requester's voter now defers for its lock) or
            # withdrawn: our allow no longer needs to lower our own priorities.
            if self._said == "allow":
                LockBook(self.space).forget_allowed(self._record)
            return
        if isinstance(message, dict) and message.get("t") == "revoked":
            if self._said == "allow" and self._revoking and message.get("k") == self._key:
                # The requester counts our allow no more: it cannot lock with it, so our
                # own requests need no longer rank below it. Our AGV asks again first,
                # then the request is voted on afresh against that one.
                LockBook(self.space).forget_allowed(self._record)
                self._unwatch()
                self._said, self._decided, self._revoking = "", None, False
                if self._revoked is not None:
                    self._revoked()
                self._evaluate()
            return
        if not isinstance(message, dict) or message.get("t") != "req":
            return
        key = message.get("k")
        if self._area is not None and key == self._key:
            return
        try:
            probe = received_request(message["a"])
            p = message["p"]
            priority = (float(p[0]), str(p[1]))
            claims = frozenset((str(seg), int(way)) for seg, way in message.get("c", ()))
            age = float(message.get(AGE_FIELD, priority[0]))
        except (KeyError, IndexError, TypeError, ValueError):
            return
        if self._area is not None:
            self._forget_request()
        else:
            # A new participation: the requester asked this node afresh (``in_group``),
            # so no allow an earlier voter of ours gave in this session counts there any
            # more; those kept a while after it left (``keep_allowed``) end now.
            LockBook(self.space).forget_allowed_in(str(self.session_id))
        self._probe, self._area, self._priority, self._claims = probe, probe.area, priority, claims
        self._key = key
        self._age = age
        self._record = f"{self.session_id}/{key}"
        self._evaluate()

    def _forget_request(self) -> None:
        if self._said == "allow":
            LockBook(self.space).forget_allowed(self._record)
        self._unwatch()
        self._round += 1
        self._said = ""
        self._decided = None
        self._revoking = False

    def _on_revoke(self, kind: str, tup: tuple[Any, ...]) -> None:
        if self._active and self._said == "allow" and not self._revoking:
            self._revoking = True
            # Not from inside the tuplespace operation, as for releases.
            self.call_later(0.0, self._send_revoke)

    def _send_revoke(self) -> None:
        if self._active and self._said == "allow" and self._revoking:
            message = {"t": "revoke", "k": self._key}
            self.send(message)
            tally_send(self._tally, "vote", message)

    def _circle_of(self, node_id: str) -> tuple[float, float, float] | None:
        props = {} if self._view is None else self._view().get(node_id, {})
        pos, radius = props.get("position"), props.get("hull_length")
        if isinstance(pos, tuple | list) and len(pos) == 2 and isinstance(radius, int | float):
            return (float(pos[0]), float(pos[1]), float(radius))
        return None

    def _on_space(self, kind: str, tup: tuple[Any, ...]) -> None:
        if self._active and self._said != "allow":
            # Not from inside the tuplespace operation: the AGV may be mid-update.
            self.call_later(0.0, self._evaluate)

    def _evaluate(self) -> None:
        probe = self._probe
        if not self._active or probe is None or self._said == "allow":
            return
        book = LockBook(self.space)
        requester = self.initiator.node_id
        circle = self._circle_of(requester)
        # Rechecks and releases mostly find the book and the requester as they were
        # (an AGV that stands still): then the verdict is the one decided on them.
        inputs = (book.version(), circle)
        decided = self._decided
        if decided is not None and decided[0] == inputs:
            verdict = decided[1]
        else:
            verdict = decide_vote(probe, self._priority, book, circle, self._claims)
            self._decided = (inputs, verdict)
        aside = (
            verdict == "priority"
            and self._blockers is not None
            and self._step_aside is not None
            and requester in self._blockers()
        )
        if verdict == "allow" or aside:
            self._unwatch()
            self._said = "allow"
            book.note_allowed(self._record, probe.area, self._priority, self._claims)
            # Our AGV may want the allow back, once its own wait is older than this
            # request (agv_app.traffic.fifo).
            space_: TupleSpace = self.space
            self._watches = [space_.notify(("revoke", self._record), self._on_revoke, on="out")]
            if aside and self._step_aside is not None:
                # The requester's lock holds up our request, so it must move first: our
                # request goes, and comes back ranked below the one we allow.
                self._step_aside()
            message: dict[str, Any] = {"t": "allow", "k": self._key}
            self.send(message)
            tally_send(self._tally, "vote", message)
            return
        if not self._watches:
            space: TupleSpace = self.space
            # Our area only shrinks when a lock or our request is taken out.
            self._watches = [
                space.notify(("lock", ANY, ANY, ANY), self._on_space, on="in"),
                space.notify(("request", ANY, ANY, ANY, ANY), self._on_space, on="in"),
            ]
            self._schedule_recheck()
        if verdict == "lock":
            # Tell our AGV that it stands in someone's way (an idle one moves off), and
            # let it inherit the age of the request it holds up: its age, not the
            # priority it was asked with, which may rank below it after a step aside.
            self.space.out(("in_the_way", requester), lease=self._recheck * 2)
            book.note_blocking(self._record, (self._age, requester), lease=self._recheck * 3)
        if verdict != self._said:
            self._said = verdict
            message = {"t": "defer", "why": verdict, "k": self._key}
            self.send(message)
            tally_send(self._tally, "vote", message)

    def _schedule_recheck(self) -> None:
        round_ = self._round

        def again() -> None:
            if self._active and self._said != "allow" and self._round == round_:
                self._evaluate()
                self._schedule_recheck()

        self.call_later(self._recheck, again)
