"""The voter's rule (:func:`decide_vote`): whether a request over a node's floor is
allowed, or why not (:mod:`agv_app.traffic.collision`)."""

from __future__ import annotations

from agv_app.geometry import Area
from agv_app.geometry.probe import Probe
from agv_app.traffic.deadlock import Claim, claims_conflict
from agv_app.traffic.lockbook import LockBook, Priority, RequestEntry
from agv_app.traffic.request_wire import WIRE_GROWTH_M

__all__ = ["decide_vote"]


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


def _covers(circle: tuple[float, float, float] | None, probe: Probe) -> bool:
    if circle is None:
        return False
    x, y, r = circle
    # The area arrived grown for the wire (request_coords); the requester's real area,
    # the one its circle covers, lies that much inside it.
    return probe.hull_length((x, y)) <= r + WIRE_GROWTH_M + 0.05
