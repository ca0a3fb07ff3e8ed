"""First come, first served at every conflict: the age of a wait.

Every request carries the **age** of the wait it serves: when its AGV began to wait
for the stretch it asks for, kept by every request asked again for that stretch
(shorter, ranked anew, after stepping aside, after an older request held it up), or
the age of an older request that the AGV's locks hold up, just ahead of it: the AGV
then moves on that request's behalf. Ages order every conflict (docs/traffic.md,
"Bounded waits"):

* **No younger request overtakes.** A voter whose own request is pending defers
  every request that conflicts with it and ranks below the age of the wait its own
  serves, even where its own priority ranks lower still (``decide_vote``). The requests
  that want one piece of floor form a queue ordered by age, kept by every AGV in it;
  none is granted while an older one that conflicts with it waits, unless it moves out
  of that one's way (inheritance, next).
* **The owner of a lock in the way moves first, at the age it holds up.** A voter that
  defers a request for one of its locks notes the request's *age* (``LockBook.
  note_blocking``), not the priority it was asked with, which may rank lower; its AGV's
  requests then carry that age (:func:`wait_age`).
* **An allow given to a younger request is taken back.** Safety ranks a request below
  every pending request its node allowed that conflicts with it, over the same floor
  or the other way through the same two-way run (``LockBook.next_priority``): a voter
  that allowed a request must not win a conflict with it. An allow given before the
  AGV's own wait became older than the request it allowed (the AGV inherited an older
  age, or asked for that floor only later) would let that younger request go first;
  so the AGV takes it back (:func:`allows_to_revoke`): its voter asks the requester to
  count the allow no more (``revoke``), and ranks below it until the requester says it
  did (``revoked``) or that the request ended (``end``), after which the request cannot
  lock with that allow. An allow given to the owner of a lock in the way (stepping
  aside) is kept: that AGV must move first.
* **A priority that fell below its age rises again.** When an allow that ranked the
  pending request lower ends, or the request allowed inherits an older age, the pending
  request is asked again at once with the priority its age now gives
  (:func:`ranks_higher`), even while a lock holds it up.

Nothing here grants anything: the votes decide, as before; ages only decide which of
two conflicting requests a voter lets through first.
"""

from __future__ import annotations

from collections.abc import Collection

from agv_app.geometry import Area
from agv_app.traffic.deadlock import Claim
from agv_app.traffic.lockbook import LockBook, Priority, RequestEntry, conflicts

__all__ = [
    "AGE_FIELD",
    "INHERITED_AHEAD_S",
    "allows_to_revoke",
    "priority_at",
    "ranks_higher",
    "wait_age",
]

AGE_FIELD = "g"
"""The field of a request message that carries its age (seconds of virtual time)."""

INHERITED_AHEAD_S = 1e-6
"""An inherited age is this much older than the request it was inherited from: the AGV
in the way ranks just ahead of the request it holds up."""


def wait_age(started: float, book: LockBook) -> float:
    """The age of a wait that began at ``started``: that time, or just ahead of the
    oldest age of the requests the node's locks hold up, if older.

    Args:
        started: when the AGV began to wait for the stretch it asks for.
        book: the node's bookkeeping (its ``blocking`` notes).
    """
    inherited = book.inherited()
    if inherited is not None and inherited < started:
        return inherited - INHERITED_AHEAD_S
    return started


def priority_at(
    age: float,
    node_id: str,
    area: Area,
    book: LockBook,
    claims: frozenset[Claim] = frozenset(),
) -> Priority:
    """The priority a request of age ``age`` over ``area`` (with direction ``claims``)
    is asked with: its age, ranked below every pending request this node allowed that
    conflicts with it (over the same floor, or the other way through the same run)."""
    return book.next_priority(age, node_id, area, claims)


def ranks_higher(entry: RequestEntry, age: float, node_id: str, book: LockBook) -> bool:
    """True if the pending request ``entry``, asked again now at ``age``, would rank
    higher than it was asked (an inherited age, or an allow that ended)."""
    return priority_at(age, node_id, entry.area, book, entry.claims) < entry.priority


def allows_to_revoke(
    age: float,
    node_id: str,
    area: Area,
    book: LockBook,
    keep: Collection[str] = (),
    claims: frozenset[Claim] = frozenset(),
) -> list[str]:
    """The allows this node should take back for its request of age ``age`` over
    ``area`` with direction ``claims``: those of pending requests younger than it that
    conflict with it, except the requests of the AGVs in ``keep`` (whose locks hold the
    request up: stepping aside let them go first on purpose).

    Returns:
        The sessions (``LockBook`` records) of those allows, oldest record first.
    """
    mine: Priority = (age, node_id)
    return [
        session
        for session, allowed, priority, theirs in book.allowed()
        if mine < priority and priority[1] not in keep and conflicts(area, claims, allowed, theirs)
    ]
