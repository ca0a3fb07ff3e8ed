"""Collision avoidance: the paper's mutual exclusion over hull projections.

Roles on ObjectPlaces (DESIGN.md, "The AGV application"):

* :class:`Requester` (initiator) asks every member of its request's collision group
  (``request_group``: the AGVs whose circles meet the box around the requested area;
  the paper's ``circles_overlap`` asks more) to allow a hull projection with a totally
  ordered priority ``(request start time, node id)``; members that join late get the request too;
  members that leave no longer count. It locks only when every current member
  allowed, every node its own view puts in the group is such a member (an activation
  still on its way counts as a missing vote), and the safe time ``2 * t_update`` has
  passed since the session started, or since a circle covering the area went out if
  the request is asked again for no more than before. Then it writes the lock to the
  tuplespace and stops the session. A request asked again whose group lies within
  the session's is asked on the open session (``ask_again``), its members kept.
* :class:`Voter` (participant) allows iff the request overlaps none of its AGV's
  requested or locked projections, or only requested ones of lower priority, and the
  requester's circle, as the voter's view has it, covers the request (the paper asks
  less: the requester in the voter's own group; see ``decide_vote``). Otherwise it defers and
  re-evaluates whenever its AGV's area shrinks (tuplespace notify) and every
  ``recheck`` seconds (its view of the requester may catch up).

A voter that allowed a request must not later win a conflict with it: its own
requests that overlap a request it allowed (until the requester says it ended, an
``end`` message, or ``keep_allowed`` after the voter left its session) get a lower
priority than that one
(:meth:`LockBook.next_priority`). Within that rule a request is asked at the *age* of
the wait it serves (:mod:`agv_app.traffic.fifo`), kept across every request asked
again for the same stretch, so the one that has waited longest wins; a request whose
age differs from its priority carries it (``"g"``).

Fairness and the wait for locks (docs/traffic.md, "Why no circle of waits forms" and
"Bounded waits"):

* A request held up by a *lock* stays pending (``patience`` None), so it keeps its
  place in line and no younger request slips past it. Instead the voter that holds it
  up with a lock inherits its age (``("blocking", ...)``: the AGV's next request
  ranks just above it), and the waiting AGV *steps aside* for that lock's owner only:
  its voter allows the owner's request, withdraws its own and asks again at once,
  ranked below the owner's (at most once per ``recheck``: the node's ``blockers``
  name nobody meanwhile, and the voter defers for priority until its next recheck).
  Once the owner asks again at the inherited age, the allow it was given ends, and the
  AGV that stepped aside asks again at its own age, just behind it.
* A request held up by an *older request* for ``queue_patience`` is asked again at
  once (same age, ``on_outwaited``): the last resort that ends the allows it was given,
  so that a younger AGV whose allow ranks it above its own is no longer held below it.

The bookkeeping all of them share lives in the node's tuplespace
(:mod:`agv_app.traffic.lockbook`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

import shapely

from agv_app.geometry import Area, coords_to_polygon, polygon_to_coords
from agv_app.geometry.probe import Probe
from agv_app.protocol import AGV_KIND, MessageTally, tally_send
from agv_app.traffic.deadlock import Claim, claims_conflict
from agv_app.traffic.fifo import AGE_FIELD
from agv_app.traffic.lockbook import LockBook, Priority, RequestEntry
from objectplaces import Initiator, Participant, ParticipantRef, groups
from objectplaces.groups import AllOf, CircleMeetsBox, GroupDefinition
from tuplespace import ANY, NotifyHandle, TupleSpace

__all__ = [
    "Requester",
    "Voter",
    "broadcast_group",
    "collision_group",
    "decide_vote",
    "group_within",
    "request_coords",
    "request_group",
]


def collision_group() -> GroupDefinition:
    """The collision-avoidance group: AGVs whose hull projection circles overlap.

    ``circles_overlap()`` restricted to AGVs, so stations (which have a position but
    no voter role) are not invited to decline every session.
    """
    return groups.circles_overlap() & groups.property_equals("kind", AGV_KIND)


def request_group(area: Area, claimed: Iterable[tuple[float, float]] = ()) -> GroupDefinition:
    """The collision group of one request: the AGVs whose circles meet the box around
    the requested area (grown as the wire grows it) and the claimed segments' vertices.

    Every AGV whose locked or requested areas, or claimed segments, the request may
    conflict with has them inside its circle, so its circle meets that box; an AGV
    whose circle only meets the requester's circle elsewhere (``collision_group``)
    cannot conflict with this request and need not vote (docs/traffic.md, "The
    collision group of a request").

    Args:
        area: the requested hull projection.
        claimed: the vertices of the segments the request claims a direction on.
    """
    extent = area.extent()
    if not extent:
        raise ValueError("a request's area is never empty")
    xs = [*extent[0::2], *(x for x, _ in claimed)]
    ys = [*extent[1::2], *(y for _, y in claimed)]
    grow = _WIRE_GROWTH_M + 0.05
    box = (min(xs) - grow, min(ys) - grow, max(xs) + grow, max(ys) + grow)
    return groups.circle_meets_box(box) & groups.property_equals("kind", AGV_KIND)


def group_within(new: GroupDefinition, old: GroupDefinition) -> bool:
    """True if ``old`` takes every node ``new`` takes, whatever the view: they are
    equal, or both are request groups (``request_group``) and ``new``'s box lies in
    ``old``'s (a circle that meets the inner box meets the outer one).

    A request asked again whose group lies within the open session's may be asked on
    that session (:meth:`Requester.ask_again`): its members stay a superset of the new
    request's group for as long as the session runs.
    """
    if new == old:
        return True
    if not isinstance(new, AllOf) or not isinstance(old, AllOf):
        return False
    if len(new.parts) != len(old.parts):
        return False
    for inner, outer in zip(new.parts, old.parts, strict=True):
        if isinstance(inner, CircleMeetsBox) and isinstance(outer, CircleMeetsBox):
            (ix0, iy0, ix1, iy1), (ox0, oy0, ox1, oy1) = inner.box, outer.box
            if (inner.position, inner.radius) != (outer.position, outer.radius) or not (
                ox0 <= ix0 and oy0 <= iy0 and ix1 <= ox1 and iy1 <= oy1
            ):
                return False
        elif inner != outer:
            return False
    return True


def broadcast_group() -> GroupDefinition:
    """Every AGV, wherever it is: the comparison mode without groups."""
    return groups.property_equals("kind", AGV_KIND)


def decide_vote(
    request: Area | Probe,
    priority: Priority,
    book: LockBook,
    circle: tuple[float, float, float] | None = None,
    claims: frozenset[Claim] = frozenset(),
) -> str:
    """The voter's rule: ``"allow"``, or why not: ``"group"``, ``"lock"`` or ``"priority"``.

    Direction claims count as area does: a request whose claims conflict with those
    of a lock (an AGV in the run, the other way) is held up by that lock; with those
    of our pending request, the priorities decide.

    A conflict with our pending request is decided by rank: the request is allowed only
    if its priority ranks above our request's priority and above the age of the wait
    ours serves, where that is older (:mod:`agv_app.traffic.fifo`).

    The group condition makes sure the voter's view already holds the requester's
    new circle: the requester's circle as the voter sees it covers the request. Then
    that circle meets the box of any request of the voter's over the requested area,
    pending or later, so the requester is a member of its group (``request_group``)
    and the voter cannot lock there without the requester's allow. Until then the
    voter defers and looks again (the circle went out before the request; a lost one
    is found at the next frame and asked for). The paper's rule, the requester in the
    voter's own circle group, is not enough once a request asks only the AGVs its box
    meets: with a stale view of the requester's circle the two circles may overlap
    while the stale circle misses the box of the voter's pending request, which then
    locks without the requester's allow over the area the voter allowed it.

    Args:
        request: the requested projection (as received); a :class:`Probe` of it
            when it is asked again and again (its answers are remembered).
        priority: the requester's priority.
        book: the voter node's bookkeeping.
        circle: the requester's ``(x, y, hull_length)`` in the voter's view.
        claims: the direction claims the request asks for.
    """
    probe = request if isinstance(request, Probe) else Probe(request)
    if not _covers(circle, probe):
        return "group"
    # Without claims of its own a request conflicts with no claim: the locks' claims
    # are looked up only when it has some.
    for key, area in book.lock_areas():
        if probe.overlaps(area) or (claims and claims_conflict(claims, book.claims_of(key))):
            return "lock"
    own = book.request()
    if (
        own is not None
        and (probe.overlaps(own.area) or claims_conflict(claims, own.claims))
        and not priority < _rank(own)
    ):
        return "priority"
    return "allow"


def _rank(own: RequestEntry) -> Priority:
    """Where our pending request stands in the queue of a conflict: its priority, or
    its age where that ranks higher. Deferring a request that ranks between the two is
    always safe, and no request younger than our wait goes first (agv_app.traffic.fifo)."""
    if own.age is None or own.age >= own.priority[0]:
        return own.priority
    return (own.age, own.priority[1])


_WIRE_GROWTH_M = 0.1


def request_coords(area: Area, *, grow_m: float = _WIRE_GROWTH_M, tolerance_m: float = 0.08) -> Any:
    """Wire form of a requested projection: grown by ``grow_m``, then simplified.

    Simplifying by less than it was grown keeps the original inside, so a voter never
    under-estimates the request; far fewer vertices travel (turn arcs are smooth).
    """
    # Vertices a hair apart (where a route turns back on itself) make the mitre
    # buffer divide by zero; dropping them moves no edge by more than a micrometre.
    clean = shapely.remove_repeated_points(area.geom, 1e-6)
    grown = clean.buffer(grow_m, join_style="mitre").simplify(tolerance_m)
    return polygon_to_coords(Area(grown), margin_m=0.0)


def _covers(circle: tuple[float, float, float] | None, probe: Probe) -> bool:
    if circle is None:
        return False
    x, y, r = circle
    # The area arrived grown for the wire (request_coords); the requester's real area,
    # the one its circle covers, lies that much inside it.
    return probe.hull_length((x, y)) <= r + _WIRE_GROWTH_M + 0.05


_REQUESTS_KEPT = 256
_requests_received: dict[Any, Probe] = {}


def _received_request(coords: Any) -> Probe:
    """A probe of ``coords_to_polygon(coords)``, shared by the voters of one process: a
    request goes to every member of the group, and on a simulated floor they all
    decode it and test it against their locks from the same requester's circle."""
    key = tuple(tuple(tuple(ring) for ring in polygon) for polygon in coords)
    probe = _requests_received.get(key)
    if probe is None:
        probe = Probe(coords_to_polygon(coords))
        if len(_requests_received) >= _REQUESTS_KEPT:
            del _requests_received[next(iter(_requests_received))]
        _requests_received[key] = probe
    return probe


def _request_message(entry: RequestEntry) -> dict[str, Any]:
    message: dict[str, Any] = {
        "t": "req",
        "k": entry.key,
        "p": [entry.priority[0], entry.priority[1]],
        "a": request_coords(entry.area),
    }
    if entry.age is not None and entry.age != entry.priority[0]:
        message[AGE_FIELD] = entry.age
    if entry.claims:
        message["c"] = [[seg, way] for seg, way in sorted(entry.claims)]
    return message


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
        self._message = _request_message(entry)
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
        self._message = _request_message(entry)
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
            probe = _received_request(message["a"])
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
