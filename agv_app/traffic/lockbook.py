"""The collision bookkeeping of one node, kept in its tuplespace.

The driving component, the requester and every voter on a node share it through the
node's tuplespace (:class:`LockBook` is typed access to these tuples):

* ``("lock", key, end_s, area)``: a locked projection (``end_s`` is the arc length of
  the route the lock reaches);
* ``("request", key, end_s, area, priority)``: the pending request;
* ``("age", key, age)``: the age of the wait the pending request ``key`` serves, where
  its priority ranks below it (:mod:`agv_app.traffic.fifo`; none: its priority's time);
* ``("claims", key, claims)``: the direction claims on two-way segments that the lock
  or request ``key`` holds (:data:`agv_app.traffic.deadlock.Claim`; none: no tuple);
* ``("stale", node_id, x, y, radius)``: the last known circle of a failed AGV, which
  nobody may lock into;
* ``("in_the_way", requester)``: a voter deferred a request because of a lock
  (leased), so an idle AGV knows to move off;
* ``("allowed", session, area, priority, claims)``: a request this node's voter
  allowed, with its direction claims, kept until its requester says it ended, or
  ``keep_allowed`` seconds after the voter left its session;
* ``("revoke", session)``: this node's AGV wants the allow of ``session`` back (leased):
  the voter that gave it asks its requester to count it no more
  (:mod:`agv_app.traffic.fifo`);
* ``("blocking", session, (age, node_id))``: a request this node's voter defers
  because of one of its locks (leased, renewed while it defers), with the age of the
  wait it serves: the AGV inherits that age (:mod:`agv_app.traffic.fifo`), so it gets
  out of the older request's way before younger ones.

``session`` in these two names the request: the voter passes ``"<session>/<key>"``, as
a session may ask again (``Requester.ask_again``) and each request counts on its own.
"""

from __future__ import annotations

from dataclasses import dataclass

from agv_app.geometry import Area, overlaps
from agv_app.traffic.deadlock import Claim, claims_conflict
from tuplespace import ANY, TupleSpace

__all__ = [
    "LockBook",
    "LockEntry",
    "Priority",
    "RequestEntry",
    "StaleRecord",
    "conflicts",
    "stale_area",
]


Priority = tuple[float, str]
"""``(request start time, node id)``: smaller is higher; ties impossible across nodes."""


@dataclass(frozen=True, slots=True)
class LockEntry:
    """A locked hull projection reaching arc length ``end_s`` of the route."""

    key: int
    end_s: float
    area: Area
    claims: frozenset[Claim] = frozenset()


@dataclass(frozen=True, slots=True)
class RequestEntry:
    """The pending request of this node's AGV (with the direction claims it asks for).

    ``age`` is the age of the wait it serves (:mod:`agv_app.traffic.fifo`; None: its
    priority's time), which its priority may rank below.
    """

    key: int
    end_s: float
    area: Area
    priority: Priority
    claims: frozenset[Claim] = frozenset()
    age: float | None = None


@dataclass(frozen=True, slots=True)
class StaleRecord:
    """What a failed AGV may still cover: its last published circle."""

    node_id: str
    x: float
    y: float
    radius: float


def conflicts(
    area: Area, claims: frozenset[Claim], other: Area, other_claims: frozenset[Claim]
) -> bool:
    """True if two requests may not both be granted: their areas overlap, or their
    direction claims conflict (opposite ways through one two-way run, whose stretches
    need not overlap)."""
    return overlaps(area, other) or claims_conflict(claims, other_claims)


def stale_area(record: StaleRecord) -> Area:
    """The circle of a stale record as an area (polygon drawn outside the circle)."""
    import shapely

    # 64 segments drawn from a radius grown by 1/cos(pi/64) circumscribe the circle.
    r = record.radius / 0.9988 + 0.01
    return Area(shapely.Point(record.x, record.y).buffer(r, quad_segs=16))


class LockBook:
    """Typed access to the collision tuples of one node's tuplespace.

    Args:
        space: the node's tuplespace.
    """

    __slots__ = ("space",)

    def __init__(self, space: TupleSpace) -> None:
        self.space = space

    def locks(self) -> list[LockEntry]:
        """Locked projections, oldest first."""
        return [
            LockEntry(t[1], t[2], t[3], self.claims_of(t[1]))
            for t in self.space.rd_all(("lock", ANY, ANY, ANY))
        ]

    def lock_areas(self) -> list[tuple[int, Area]]:
        """``(key, area)`` of each locked projection, oldest first (``locks`` without
        the claims, which cost a lookup per lock)."""
        return [(t[1], t[3]) for t in self.space.rd_all(("lock", ANY, ANY, ANY))]

    def version(self) -> tuple[int, int, int]:
        """Unchanged as long as the locks, the request and their claims are: what a
        vote reads of the book (``TupleSpace.version``)."""
        space = self.space
        return space.version("lock"), space.version("request"), space.version("claims")

    def claims_of(self, key: int) -> frozenset[Claim]:
        """The direction claims the lock or request ``key`` holds."""
        t = self.space.rdp(("claims", key, ANY))
        return frozenset() if t is None else t[2]

    def _set_claims(self, key: int, claims: frozenset[Claim]) -> None:
        self.space.in_all(("claims", key, ANY))
        if claims:
            self.space.out(("claims", key, claims))

    def claims(self) -> frozenset[Claim]:
        """Every direction claim the locks hold."""
        return frozenset(
            c for t in self.space.rd_all(("lock", ANY, ANY, ANY)) for c in self.claims_of(t[1])
        )

    def request(self) -> RequestEntry | None:
        """The pending request, if any."""
        t = self.space.rdp(("request", ANY, ANY, ANY, ANY))
        if t is None:
            return None
        age = self.space.rdp(("age", t[1], ANY))
        return RequestEntry(
            t[1], t[2], t[3], t[4], self.claims_of(t[1]), None if age is None else age[2]
        )

    def lock_end(self, default: float = 0.0) -> float:
        """The furthest arc length any lock reaches (``default`` without locks)."""
        return max((t[2] for t in self.space.rd_all(("lock", ANY, ANY, ANY))), default=default)

    def add_request(self, entry: RequestEntry) -> None:
        """Record the pending request (there is at most one), with its age where its
        priority ranks below it."""
        self._set_claims(entry.key, entry.claims)
        if entry.age is not None and entry.age != entry.priority[0]:
            self.space.out(("age", entry.key, entry.age))
        self.space.out(("request", entry.key, entry.end_s, entry.area, entry.priority))

    def grant(self, key: int) -> LockEntry | None:
        """Turn the request ``key`` into a lock (written before the request is taken)."""
        t = self.space.rdp(("request", key, ANY, ANY, ANY))
        if t is None:
            return None
        entry = LockEntry(key, t[2], t[3], self.claims_of(key))
        self.space.out(("lock", key, entry.end_s, entry.area))
        self.space.inp(("request", key, ANY, ANY, ANY))
        self.space.inp(("age", key, ANY))
        return entry

    def withdraw(self, key: int) -> bool:
        """Drop the request ``key``; False if it was not pending."""
        gone = self.space.inp(("request", key, ANY, ANY, ANY)) is not None
        if gone:
            self._set_claims(key, frozenset())
            self.space.inp(("age", key, ANY))
        return gone

    def set_locks(self, entry: LockEntry) -> None:
        """Replace every lock by ``entry`` (the release: new lock written first)."""
        old = self.space.rd_all(("lock", ANY, ANY, ANY))
        self._set_claims(entry.key, entry.claims)
        self.space.out(("lock", entry.key, entry.end_s, entry.area))
        for t in old:
            self.space.inp(t)
            if t[1] != entry.key:
                self._set_claims(t[1], frozenset())

    def clear(self) -> None:
        """Drop every lock and request (the node restarts from nothing)."""
        self.space.in_all(("lock", ANY, ANY, ANY))
        self.space.in_all(("request", ANY, ANY, ANY, ANY))
        self.space.in_all(("claims", ANY, ANY))
        self.space.in_all(("age", ANY, ANY))

    def note_allowed(
        self,
        session_id: str,
        area: Area,
        priority: Priority,
        claims: frozenset[Claim] = frozenset(),
    ) -> None:
        """Remember that this node allowed a request (its area and direction claims), as
        long as our vote may count: until its requester says it ended
        (:meth:`forget_allowed`), or a while after the voter left the session
        (:meth:`keep_allowed`)."""
        self.space.in_all(("allowed", session_id, ANY, ANY, ANY))
        self.space.out(("allowed", session_id, area, priority, claims))

    def keep_allowed(self, session_id: str, keep: float) -> None:
        """Remember the allowed request of ``session_id`` for ``keep`` seconds more.

        For when the voter left the session: the request may still be pending (our vote
        merely stopped counting, or its requester has not yet heard that we left), and
        remembering too long only lowers our own priority, which is always safe.
        """
        for t in self.space.in_all(("allowed", session_id, ANY, ANY, ANY)):
            self.space.out(t, lease=keep)

    def allowed(self) -> list[tuple[str, Area, Priority, frozenset[Claim]]]:
        """The requests this node allowed and still ranks below: ``(session, area,
        priority, claims)``, oldest record first."""
        return [
            (t[1], t[2], t[3], t[4]) for t in self.space.rd_all(("allowed", ANY, ANY, ANY, ANY))
        ]

    def revoke(self, session_id: str, *, lease: float) -> None:
        """Ask, for ``lease`` seconds, that the allow of ``session_id`` be taken back
        (its voter watches for this; :mod:`agv_app.traffic.fifo`)."""
        self.space.in_all(("revoke", session_id))
        self.space.out(("revoke", session_id), lease=lease)

    def forget_allowed_in(self, session: str) -> None:
        """Forget every request of session ``session`` this node allowed (records named
        ``"<session>/<key>"``): its requester counts none of those allows any more."""
        prefix = f"{session}/"
        for t in self.space.rd_all(("allowed", ANY, ANY, ANY, ANY)):
            if str(t[1]).startswith(prefix):
                self.space.inp(t)

    def forget_allowed(self, session_id: str) -> None:
        """Forget that this node allowed the request of ``session_id``: its requester
        said it is locked or withdrawn, so it no longer outranks our requests."""
        self.space.in_all(("allowed", session_id, ANY, ANY, ANY))

    def note_blocking(self, session_id: str, age: Priority, *, lease: float) -> None:
        """Remember for ``lease`` seconds that one of our locks holds up a request whose
        wait has age ``(age, requester)``."""
        self.space.in_all(("blocking", session_id, ANY))
        self.space.out(("blocking", session_id, age), lease=lease)

    def inherited(self) -> float | None:
        """The oldest age of the requests our locks hold up (None: none)."""
        times = [float(t[2][0]) for t in self.space.rd_all(("blocking", ANY, ANY))]
        return min(times, default=None)

    def next_priority(
        self, wanted: float, node_id: str, area: Area, claims: frozenset[Claim] = frozenset()
    ) -> Priority:
        """A priority for a new request over ``area`` with direction ``claims``, at time
        ``wanted`` if it may.

        It is lower than that of every pending request this node allowed that conflicts
        with it (:func:`conflicts`): a voter that allowed a request must not win a
        conflict with it.
        """
        mine: Priority = (wanted, node_id)
        for t in self.space.rd_all(("allowed", ANY, ANY, ANY, ANY)):
            theirs: Priority = t[3]
            if mine <= theirs and conflicts(area, claims, t[2], t[4]):
                mine = (theirs[0] + 1e-6, node_id)
        return mine

    def stale(self) -> list[StaleRecord]:
        """Stale-node records, oldest first."""
        return [
            StaleRecord(t[1], t[2], t[3], t[4])
            for t in self.space.rd_all(("stale", ANY, ANY, ANY, ANY))
        ]

    def add_stale(self, record: StaleRecord) -> None:
        """Record a failed AGV's circle (replacing an older record of the same node)."""
        self.drop_stale(record.node_id)
        self.space.out(("stale", record.node_id, record.x, record.y, record.radius))

    def drop_stale(self, node_id: str) -> bool:
        """Forget the record of ``node_id`` (it came back); False if there was none."""
        return bool(self.space.in_all(("stale", node_id, ANY, ANY, ANY)))

    def hits_stale(self, area: Area) -> bool:
        """True if ``area`` overlaps the circle of any stale record."""
        return any(overlaps(area, stale_area(r), tolerance_m2=0.0) for r in self.stale())
