"""The tasks of an AGV: bidding, taking, the legs to the stations, dwelling, going home.

It carries out tasks: to the pick station, dwell, to the drop station, dwell, home to
its own parking spot. It is free for the next task as soon as it dwells at the drop
station (it bids from there and, awarded, sets off for the next pick without going
home); one awarded a task on its way home stops at the first point ahead from which the
pick station is nearer than by way of home, and sets off from there. The
:class:`~agv_app.vehicle.controller.AgvController` owns one :class:`Errands`; the state
it works on (task, phase, dwell) is the controller's.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from agv_app.tasks.auction import TaskSpec
from agv_app.vehicle.closures import serves
from tuplespace import ANY

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = ["Errands"]

_DEPART_SLACK_S = 0.2  # a request before departure starts this much before the safe time


class Errands:
    """The tasks of one AGV (its controller's state, this job's logic).

    Args:
        agv: the controller whose tasks these are.
    """

    def __init__(self, agv: AgvController) -> None:
        self._agv = agv

    def bid_for(self, task: TaskSpec) -> float | None:
        """Route distance to the pick station, or None if busy or failed.

        On the way home it is the distance by way of the point the AGV would stop at
        if awarded (:meth:`turn_point`).
        """
        agv = self._agv
        if agv.failed or agv._held or not agv.in_service or agv.sent_home:
            return None
        if agv.status != "idle":
            return None
        if not serves(agv, task):
            return None
        pick = agv.layout.station(task.pick).point
        if agv._dest is None:
            distance = agv.distance(agv.point, pick)
            return None if math.isinf(distance) else distance
        turn = self.turn_point(pick)
        if turn is not None:
            return turn[2]
        distance = agv.distance(agv._dest, pick)
        return None if math.isinf(distance) else agv.vehicle.remaining() + distance

    def take(self, task: TaskSpec) -> None:
        """Accept an awarded task: go to its pick station as soon as the AGV is at rest
        (on its way home: at the point :meth:`turn_point` picks)."""
        agv = self._agv
        agv.pending_task = task
        agv.node.update_node_property("task", task.id)
        self.turn_for_pending()
        agv.publish()

    def turn_point(self, pick: str) -> tuple[str, float, float] | None:
        """Where an AGV driving home best stops to set off for point ``pick``:
        ``(point, arc length, distance to pick by way of it)``, or None when home is
        as good (or no point ahead will do).

        Candidates are the route's points at or beyond everything locked or requested
        (the vehicle can stop there without giving anything back), clear of every
        no-rest zone.
        """
        agv = self._agv
        route, plan, dest = agv._route, agv._plan, agv._dest
        if route is None or plan is None or dest is None or route.end != dest:
            return None
        vehicle, book = agv.vehicle, agv.book
        reach = book.lock_end(default=vehicle.s)
        pending = book.request()
        if pending is not None:
            reach = max(reach, pending.end_s)
        home_cost = vehicle.remaining() + agv.distance(dest, pick)
        best: tuple[str, float, float] | None = None
        for point, offset in zip(route.points[:-1], route.offsets[:-1], strict=True):
            s = offset + agv._route_shift
            if s < reach - 1e-9 or any(lo - 1e-6 <= s <= hi + 1e-6 for lo, hi in plan.zones):
                continue
            cost = s - vehicle.s + agv.distance(point, pick)
            if cost < home_cost - 1e-6 and (best is None or cost < best[2]):
                best = (point, s, cost)
        return best

    def turn_for_pending(self) -> None:
        """On the way home with a task awarded: end the route at the turn point."""
        agv = self._agv
        task = agv.pending_task
        if task is None or agv.phase != "to_home" or agv._resume is not None:
            return
        turn = self.turn_point(agv.layout.station(task.pick).point)
        if turn is None or agv._plan is None or agv._route is None:
            return
        point, s, _ = turn
        agv.vehicle.shorten_route(s)
        agv._plan = agv._plan.cut(s)
        # The route ends there too: driving on (``LastResorts.drive_on``) sets out from its points.
        points = agv._route.points
        agv._route = agv.layout.route_through(points[: points.index(point) + 1])
        agv._dest = point

    def arrived(self, now: float) -> None:
        """The vehicle reached the end of its route: go on where a yield or drive-on
        resumes, dwell at a station, or rest at home."""
        agv = self._agv
        assert agv._dest is not None
        agv.point = agv._dest
        agv._dest = None
        agv._plan = None
        agv._route = None
        if agv._resume is not None:
            # Bound home, it goes to the home it has now: a yield may have moved it to
            # the place it just reached, and the old one is someone else's to take.
            resume = agv.home if agv.phase == "to_home" else agv._resume
            agv._resume = None
            if agv.routing.route_to(resume) or agv.blocked_to is not None:
                agv.publish()
                return
        if agv.phase in ("to_pick", "to_drop"):
            self.dwell(now)
        else:
            agv.phase = "home"
        agv.publish()

    def dwell(self, now: float) -> None:
        """Stand at the station of the task's leg for ``dwell``. The stations hear where
        the AGV is bound (a station calls its next AGV when none is on its way to it):
        at the pick station ``reached_pick`` and the drop station (``dropping_at``),
        at the drop station that it is there."""
        agv = self._agv
        if agv.phase == "to_pick":
            agv.phase = "at_pick"
            if agv.task is not None:
                agv.node.update_node_property("reached_pick", agv.task.id)
                agv.node.update_node_property("dropping_at", agv.task.drop)
        else:
            agv.phase = "at_drop"
            agv.node.update_node_property("dropping_at", None)
        agv._dwell_until = now + agv.config.dwell

    def idle(self, now: float) -> None:
        """Standing with no route: move out of someone's way, end a dwell, set off with
        a task, or go home."""
        agv = self._agv
        resting = agv.phase == "home" and agv.point == agv.home
        if resting and agv.pending_task is None:
            in_the_way = agv.node.space.in_all(("in_the_way", ANY))
            if not in_the_way or agv._relocate is None:
                return
            home = agv._relocate(agv)
            if home is None or home == agv.home:
                return
            agv.home = home
        if agv.phase in ("at_pick", "at_drop"):
            if now < agv._dwell_until - self.departure_lead():
                return
            # The route is set while the AGV still dwells, so that its first request
            # is granted as the dwell ends; the vehicle stands until then.
            agv._hold_until = agv._dwell_until
        if agv.phase == "at_pick" and agv.task is not None:
            agv.phase = "to_drop"
            agv.routing.route_to(agv.layout.station(agv.task.drop).point)
        elif agv.phase == "at_drop" and agv.task is not None:
            agv._done_later = agv.task.id
            agv.task = None
            if now >= agv._hold_until:
                self.report_done()
            if agv.pending_task is not None:
                self.start_pending()  # awarded while dwelling: no drive home
            else:
                self.go_home()
        elif agv.pending_task is not None:
            self.start_pending()
        elif agv.phase != "home" or agv.point != agv.home:
            self.go_home()
        if agv._dest is None and agv.blocked_to is None and agv.phase in ("to_pick", "to_drop"):
            self.dwell(now)  # already standing there
        agv.publish()

    def departure_lead(self) -> float:
        """Seconds before the end of a dwell at which the next route is set: the safe
        time a request waits (and a little), none with the central scheduler, which
        grants at once."""
        agv = self._agv
        if agv._central is not None:
            return 0.0
        return 2 * agv.config.t_update + _DEPART_SLACK_S

    def report_done(self) -> None:
        """Report the task finished at the drop station (when its dwell ends)."""
        agv = self._agv
        done = agv._done_later
        assert done is not None
        agv._done_later = None
        agv.last_done = done
        agv.node.update_node_property("last_done", done)
        # The next task may have been taken (or started) in the meantime.
        current = agv.task or agv.pending_task
        agv.node.update_node_property("task", None if current is None else current.id)
        if agv._on_task_done is not None:
            agv._on_task_done(done)

    def start_pending(self) -> None:
        """Set off with the task awarded: to its pick station, or with a load handed back
        after a restart, to its drop station."""
        agv = self._agv
        assert agv.pending_task is not None
        agv.task, agv.pending_task = agv.pending_task, None
        back, agv.handed_back = agv.handed_back, None
        loaded = back is not None and back.resumed(agv.node, agv.task)
        agv.phase = "to_drop" if loaded else "to_pick"
        if agv._on_task_started is not None:
            agv._on_task_started(agv.task.id)
        station = agv.task.drop if loaded else agv.task.pick
        agv.routing.route_to(agv.layout.station(station).point)

    def go_home(self) -> None:
        """Drive home (home already: rest there)."""
        agv = self._agv
        agv.phase = "to_home"
        agv.routing.route_to(agv.home)
        if agv._dest is None and agv.blocked_to is None:
            agv.phase = "home"
