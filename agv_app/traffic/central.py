"""The central baseline: one scheduler with global knowledge grants every lock.

What ``objectplaces sim --traffic central`` runs instead of the requester and voter
roles, so the decentralised protocol has a yardstick: an openTCS-style scheduler that
sees every AGV's locks and requests at once, with no network between it and the
vehicles. It grants the same lock areas (hull projections from one resting place to
the next, :mod:`agv_app.traffic.deadlock`, with their direction claims) first come,
first served: waiting requests in the order their AGVs started waiting, each granted
as soon as it overlaps no other AGV's lock and claims nothing against one. It
reserves nothing for a request that must wait (as openTCS's scheduler allocates free
resources and lets a blocked claim wait).

Deadlock handling is what the vehicles bring, as with openTCS's resting-place rules:
requests end at resting places, and an AGV stuck at a dead-end dock yields after
``yield_after`` (the scheduler tells it which locks hold its request up). Without
that discipline a central scheduler jams too.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field

from agv_app.geometry import overlaps
from agv_app.traffic.deadlock import claims_conflict
from agv_app.traffic.lockbook import LockBook, LockEntry, RequestEntry

__all__ = ["CentralRequest", "CentralScheduler"]


@dataclass(eq=False, slots=True)
class CentralRequest:
    """One AGV's request as the central scheduler holds it.

    Attributes:
        agv_id: the requesting AGV.
        entry: the request, as recorded in the AGV's lock book.
        on_done: called once with ``"locked"`` or ``"withdrawn"``.
        done: ``""`` while pending, then ``"locked"`` or ``"withdrawn"``.
        blocked_by: the AGVs whose locks held the request up at the last attempt.
    """

    agv_id: str
    entry: RequestEntry
    on_done: Callable[[str], None]
    scheduler: CentralScheduler
    done: str = ""
    blocked_by: frozenset[str] = field(default_factory=frozenset)

    def check(self) -> None:
        """Try to grant the waiting requests now."""
        self.scheduler.grant_waiting()

    def withdraw(self) -> None:
        """Drop the request (the AGV yields or gives up)."""
        self.scheduler.withdraw(self)


class CentralScheduler:
    """Grants lock requests first come, first served, from every AGV's lock book.

    Args:
        in_the_way_lease: seconds an ``in_the_way`` note lives in the space of an AGV
            whose lock holds a request up (an idle AGV then moves off, as with votes).
    """

    def __init__(self, *, in_the_way_lease: float = 1.0) -> None:
        self._books: dict[str, Callable[[], LockBook]] = {}
        self._waiting: dict[str, CentralRequest] = {}
        self._lease = in_the_way_lease
        self._order = itertools.count()
        self._arrival: dict[str, int] = {}

    def register(self, agv_id: str, book: Callable[[], LockBook]) -> None:
        """Know ``agv_id`` and where its locks are kept."""
        self._books[agv_id] = book

    def submit(
        self, agv_id: str, entry: RequestEntry, on_done: Callable[[str], None]
    ) -> CentralRequest:
        """Queue a request (already in the AGV's lock book); ``check()`` grants it."""
        request = CentralRequest(agv_id, entry, on_done, self)
        self._waiting[agv_id] = request
        self._arrival[agv_id] = next(self._order)
        return request

    def pending(self, agv_id: str) -> CentralRequest | None:
        """The request ``agv_id`` waits with, if any."""
        return self._waiting.get(agv_id)

    def withdraw(self, request: CentralRequest) -> None:
        """Drop ``request`` if it is still waiting."""
        if request.done or self._waiting.get(request.agv_id) is not request:
            return
        del self._waiting[request.agv_id]
        self._finish(request, "withdrawn")

    def grant_waiting(self) -> None:
        """Grant every waiting request that overlaps no other AGV's lock, in order."""
        if not self._waiting:
            return
        locks = {a: book().locks() for a, book in self._books.items()}
        queue = sorted(
            self._waiting.values(), key=lambda r: (r.entry.priority, self._arrival[r.agv_id])
        )
        for request in queue:
            entry = request.entry
            blockers = frozenset(
                other
                for other, held in locks.items()
                if other != request.agv_id
                and any(
                    overlaps(entry.area, e.area) or claims_conflict(entry.claims, e.claims)
                    for e in held
                )
            )
            request.blocked_by = blockers
            if blockers:
                for other in blockers:
                    self._books[other]().space.out(
                        ("in_the_way", request.agv_id), lease=self._lease
                    )
                continue
            del self._waiting[request.agv_id]
            granted = LockEntry(entry.key, entry.end_s, entry.area, entry.claims)
            locks[request.agv_id] = [*locks.get(request.agv_id, []), granted]
            self._finish(request, "locked")

    def _finish(self, request: CentralRequest, outcome: str) -> None:
        request.done = outcome
        book = self._books[request.agv_id]()
        if outcome == "locked":
            book.grant(request.entry.key)
        else:
            book.withdraw(request.entry.key)
        request.on_done(outcome)
