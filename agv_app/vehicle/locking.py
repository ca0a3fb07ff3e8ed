"""How an AGV asks for floor: its requests ahead, their review, its locks.

The :class:`~agv_app.vehicle.controller.AgvController` owns one :class:`Locking`; the
state it works on (the pending requester, first try, retry time, request length) is the
controller's. Every step the controller asks for the next stretch before it runs out
of locked area (``request_ahead``), reviews the pending request once per update
interval (``review_request``), and gives back what it has driven over (``release``).
The requester's end (``request_done``) may lead to a last resort
(:mod:`agv_app.vehicle.last_resort`). The voter of the AGV asks here whom to step aside
for (``blockers``, ``step_aside``, ``revoked``): docs/traffic.md, "Bounded waits".
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from agv_app.geometry import Area, hull_projection, projection_ahead
from agv_app.traffic.central import CentralRequest
from agv_app.traffic.collision import Requester, broadcast_group, request_group
from agv_app.traffic.deadlock import Claim
from agv_app.traffic.fifo import allows_to_revoke, priority_at, ranks_higher, wait_age
from agv_app.traffic.lockbook import LockEntry, RequestEntry
from objectplaces.groups import GroupDefinition

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = ["Announced", "Locking"]

_MIN_ADVANCE_M = 1.25  # the shortest stretch a request held up by a lock shrinks to
_SHRINK_WORTH_M = 5.0  # a circle this much smaller is worth a publication to every listener

Announced = tuple[float, Area, frozenset[Claim]]
"""Since when a published circle covers a request, its area and direction claims."""


class Locking:
    """The requests and locks of one AGV (its controller's state, this job's logic).

    Args:
        agv: the controller whose requests and locks these are.
    """

    def __init__(self, agv: AgvController) -> None:
        self._agv = agv
        self._asking_again = False
        self._aside_at = -math.inf
        self._next_release = 0.0

    def step(self, now: float) -> None:
        """The locks' part of a driving step: withdraw the request when nobody hears us,
        ask for the next stretch, and once per update interval review the request and
        release what the vehicle has driven over."""
        agv = self._agv
        requester = agv._requester
        if (
            requester is not None
            and not requester.done
            and agv.cut_off.isolated(len(agv.node.view()))
        ):
            requester.withdraw()  # with nobody to vote, a request would lock alone
        self.request_ahead(now)
        if now >= self._next_release:
            self._next_release = now + agv.config.t_update
            if agv._requester is not None:
                agv._requester.check()
                self.review_request(now)
            if agv.vehicle.s > agv._released_at_s + 1e-6:
                self.release()

    def blockers(self) -> frozenset[str]:
        """The nodes whose locks hold up our pending request, that a voter of ours steps
        aside for; none for ``t_update / 2`` after we stepped aside: a circle of AGVs
        each holding up the next would otherwise step aside round it at every round
        trip, each step a new request to its whole group."""
        agv = self._agv
        requester = agv._requester
        if requester is None or agv.node.now() < self._aside_at + agv.config.t_update / 2:
            return frozenset()
        return requester.blocked_by

    def step_aside(self) -> None:
        """A voter of ours allowed the request of a node whose lock holds up ours: ask
        again, ranked below it."""
        agv = self._agv
        self._aside_at = agv.node.now()
        self.ask_again()

    def revoked(self) -> None:
        """An allow this AGV took back counts no more: ask again at the priority its
        age now gives, if that ranks higher (agv_app.traffic.fifo)."""
        agv = self._agv
        requester = agv._requester
        if (
            isinstance(requester, Requester)
            and not requester.done
            and ranks_higher(requester.entry, self.age(), agv.node_id, agv.book)
        ):
            self.ask_again()

    def ask_again(self) -> None:
        """Withdraw the pending request and make a new one at once (no gap in which
        younger requests would find our area free); its priority is worked out anew."""
        agv = self._agv
        requester = agv._requester
        if requester is None:
            return
        prior = agv._announced
        # The session stays open: the new request is asked on it if its group lies
        # within the old one's, keeping the members and their channels.
        kept = requester if isinstance(requester, Requester) else None
        self._asking_again = True
        try:
            if kept is not None:
                kept.withdraw(keep_session=True)
            else:
                requester.withdraw()
        finally:
            self._asking_again = False
        agv._retry_at = 0.0
        self.request_ahead(agv.node.now(), prior, kept)
        if kept is not None:
            kept.close()  # nothing if the new request was asked on it

    def age(self) -> float:
        """The age of the wait a request serves: when the AGV started waiting for this
        stretch, or the older age of a request its locks hold up (inherited)."""
        agv = self._agv
        assert agv._first_try is not None
        return wait_age(agv._first_try[1], agv.book)

    def request_ahead(
        self, now: float, prior: Announced | None = None, kept: Requester | None = None
    ) -> None:
        """Ask for the next stretch ahead, if the locks end within reach of a stop at
        top speed (``prior`` and ``kept``: the request just withdrawn to ask again)."""
        agv = self._agv
        if agv._requester is not None or agv._plan is None or now < agv._retry_at or agv._held:
            return
        if agv.cut_off.isolated(len(agv.node.view())):
            return  # it hears nothing: it drives on inside its locks only, and stops
        vehicle, spec, book = agv.vehicle, agv.spec, agv.book
        lock_end = book.lock_end(default=vehicle.s)
        if lock_end >= agv._plan.length - 1e-9:
            return
        safe_time = 2 * agv.config.t_update
        need = spec.braking_distance(spec.max_speed_m_s) + spec.max_speed_m_s * (safe_time + 0.5)
        if lock_end - vehicle.s > need:
            return
        follow = agv.config.direction_claims
        end = agv._plan.next_stop(lock_end, agv._advance, follow=follow)
        if agv._advance < agv.config.advance_m and not agv._plan.may_rest(end):
            # A shortened request ends only where the AGV may rest outside every run,
            # never inside one it follows through (at a dead-end start that place can
            # be with the hull still in the lane it joins).
            end = agv._plan.next_stop(lock_end, agv.config.advance_m, follow=follow)
        claims = agv._plan.claims_between(lock_end, end) if follow else frozenset()
        area = hull_projection(
            vehicle.route, lock_end, end, length=spec.length_m, width=spec.width_m
        )
        if book.hits_stale(area):
            agv._retry_at = now + agv.config.retry
            return
        agv._key += 1
        if agv._first_try is None or agv._first_try[0] != lock_end:
            agv._first_try = (lock_end, now)
        age = self.age()
        priority = priority_at(age, agv.node_id, area, book, claims)
        entry = RequestEntry(agv._key, end, area, priority, claims, age)
        book.add_request(entry)
        # A request inside the circle in force needs no new one: the others have had
        # it since it went out (docs/traffic.md, "A request inside the published circle").
        covered_since = agv.publication.covered_since()
        if covered_since is None:
            agv.publish()
            covered_since = now
        announced_at = min(covered_since, self.announced_at(now, area, claims, prior))
        agv._announced = (announced_at, area, claims)
        if agv._central is not None:
            request = agv._central.submit(
                agv.node_id, entry, lambda outcome: self.request_done(request, outcome)
            )
            agv._requester = request
            request.check()
            return
        definition = self.group_of(area, claims)
        if kept is not None:
            if kept.ask_again(entry, definition, announced_at=announced_at):
                agv._requester = kept
                return
            kept.close()
        requester = Requester(
            entry,
            safe_time=safe_time,
            patience=agv.config.patience,
            queue_patience=agv.config.queue_patience,
            group_view=lambda: agv.node.view_group(definition),
            on_done=lambda outcome: self.request_done(requester, outcome),
            tally=agv.tally,
            announced_at=announced_at,
            definition=definition,
            vote_deadline=agv.config.vote_deadline,
            on_silent=agv.peers.silent,
            on_outwaited=self.ask_again,
        )
        agv._requester = requester
        agv.node.start_interaction(requester, definition, "voter")

    def announced_at(
        self, now: float, area: Area, claims: frozenset[Claim], prior: Announced | None
    ) -> float:
        """Since when a published circle covers ``area``: ``now``, or, asked again for
        no more than the withdrawn request (area and claims), the time that request's
        circle went out: every circle published while it was pending covered it too."""
        if prior is None:
            return now
        since, before, claimed = prior
        if not claims <= claimed or not before.geom.buffer(1e-6).covers(area.geom):
            return now
        return since

    def group_of(self, area: Area, claims: frozenset[Claim]) -> GroupDefinition:
        """The group a request asks: every AGV in broadcast mode, else the AGVs whose
        circles meet the area or the claimed segments (``request_group``)."""
        agv = self._agv
        if agv.config.broadcast:
            return broadcast_group()
        claimed = [xy for seg, _ in claims for xy in agv.layout.segment_coords(seg)]
        return request_group(area, claimed)

    def request_done(self, requester: Requester | CentralRequest, outcome: str) -> None:
        """A request ended (``locked``, else withdrawn): on to the next stretch, or a try
        again after ``retry`` and, held up by a lock long enough, a last resort."""
        agv = self._agv
        if agv._requester is not requester:
            return
        agv._requester = None
        now = agv.node.now()
        if outcome == "locked":
            agv._advance = agv.config.advance_m
            if agv._on_lock_wait is not None and agv._first_try is not None:
                agv._on_lock_wait(now - agv._first_try[1])
        elif not self._asking_again:
            agv._retry_at = now + agv.config.retry
            if requester.blocked_by and agv._must_yield(now):
                agv.last_resorts.back_off()
            elif requester.blocked_by and agv._must_drive_on(now, requester):
                agv.last_resorts.drive_on()
            elif requester.blocked_by and agv._must_detour(now, requester):
                agv.last_resorts.detour()
            agv.publish()

    def review_request(self, now: float) -> None:
        """Withdraw the pending request to yield (see ``LastResorts.must_yield``), take back the
        allows that let younger requests over its floor go first, ask for less while a
        lock holds it up, or ask again if it would now rank higher (an inherited age, or
        an allow that ranked it lower ended: agv_app.traffic.fifo).

        Held up by a lock, it asks again to rank higher only without ``patience``,
        which asking again would restart.
        """
        agv = self._agv
        requester = agv._requester
        if requester is None or requester.done or agv._held:
            return  # held: it stands where it is, and yields or detours for nobody
        if requester.blocked_by and (
            (agv._must_yield(now) and agv.last_resorts.yield_place() is not None)
            or agv._must_drive_on(now, requester)
            or agv._must_detour(now, requester)
        ):
            requester.withdraw()
            return
        if isinstance(requester, Requester):
            # Allows given to younger requests over our floor let them go first: take
            # them back, but not those of the AGVs whose locks are in our way.
            entry = requester.entry
            for session in allows_to_revoke(
                self.age(), agv.node_id, entry.area, agv.book, requester.blocked_by, entry.claims
            ):
                agv.book.revoke(session, lease=2 * agv.config.t_update)
        if requester.blocked_by:
            if self.may_shorten():
                # Held up by a lock while standing: ask for half the stretch, which
                # may fit behind the AGV ahead (followers close up on a full lane).
                agv._advance = max(_MIN_ADVANCE_M, agv._advance / 2)
                self.ask_again()
                return
            if agv.config.patience is not None:
                return
        if ranks_higher(requester.entry, self.age(), agv.node_id, agv.book):
            self.ask_again()

    def may_shorten(self) -> bool:
        """True if the standing AGV's pending request may be asked again shorter."""
        agv = self._agv
        return (
            agv.config.patience is None
            and agv.vehicle.speed == 0.0
            and agv._advance > _MIN_ADVANCE_M
        )

    def release(self) -> None:
        """Give back the locked area the vehicle has driven over (and the claims behind)."""
        agv = self._agv
        vehicle, spec, book = agv.vehicle, agv.spec, agv.book
        lock_end = book.lock_end(default=vehicle.s)
        area = projection_ahead(
            vehicle.route, vehicle.s, lock_end, length=spec.length_m, width=spec.width_m
        )
        held = book.claims()
        if agv._plan is not None:
            held &= agv._plan.claims_held(vehicle.s, lock_end)
        agv._key += 1
        book.set_locks(LockEntry(agv._key, lock_end, area, held))
        agv._released_at_s = vehicle.s
        # Shrinking is optional for safety (the old circle still covers what is left);
        # publish it when it is worth the message: fewer AGVs in our next groups.
        published = agv.node.properties.get("hull_length")
        if (
            not isinstance(published, float)
            or agv.current_hull_length() < published - _SHRINK_WORTH_M
        ):
            agv.publish()
