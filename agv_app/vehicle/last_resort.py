"""The last resorts of an AGV held up by a lock: yielding, driving on, taking another way.

docs/traffic.md, "Yielding", "Driving on" and "Taking another way". Each is a test
(``must_yield``, ``must_drive_on``, ``must_detour``; the controller's methods of those
names call them, and a subclass may narrow them) and an act that sets a new route
(``back_off``, ``drive_on``, ``detour``). The :class:`~agv_app.vehicle.controller.AgvController`
owns one :class:`LastResorts`; the state it works on is the controller's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from agv_app.geometry import Polyline
from agv_app.layout.elements import NoRouteError, Route
from agv_app.traffic.central import CentralRequest
from agv_app.traffic.collision import Requester
from agv_app.vehicle.routing import LEAD_M

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = ["LastResorts"]


class LastResorts:
    """The last resorts of one AGV (its controller's state, this job's logic).

    Args:
        agv: the controller whose AGV they move.
    """

    def __init__(self, agv: AgvController) -> None:
        self._agv = agv
        self._no_drive_on_until = 0.0
        """No drive-on before then (the last one found no other way on)."""
        self._no_detour_until = 0.0
        """No other way taken before then (the last try was then)."""

    def must_yield(self, now: float) -> bool:
        """True if the AGV has not left its start, stands where it may not rest, and has
        waited ``yield_after`` for its first lock: someone needs the run it stands in."""
        agv = self._agv
        plan, vehicle = agv._plan, agv.vehicle
        return (
            plan is not None
            and agv._resume is None
            and agv.point != agv.home  # its home is a waiting place already
            and vehicle.s <= LEAD_M + 1e-6
            and agv.book.lock_end(default=vehicle.s) <= vehicle.s + 1e-6
            and not plan.may_rest(vehicle.s)
            and now - agv._route_started_at >= agv.config.yield_after
        )

    def yield_place(self) -> str | None:
        """Where yielding would take the AGV: its home, else a free rest point (which
        becomes its home); None where there is no such place (every rest point taken).
        Without one, a pending request is kept: withdrawn, it only started again."""
        agv = self._agv
        dest = agv._dest
        place: str | None = agv.home
        if place in (agv.point, dest) and agv._relocate is not None:
            place = agv._relocate(agv)
            if place is not None:
                agv.home = place
        return None if place is None or place in (agv.point, dest) else place

    def back_off(self) -> None:
        """Back off to a waiting place (home, else a free rest point), then go on."""
        agv = self._agv
        dest = agv._dest
        assert dest is not None
        place = self.yield_place()
        if place is None:
            return
        phase = agv.phase
        agv.routing.route_to(place)
        agv.phase = phase
        agv._resume = dest
        if agv._on_last_resort is not None:
            agv._on_last_resort("yield")

    def must_drive_on(self, now: float, requester: Requester | CentralRequest) -> bool:
        """True if the AGV stands on its way, past its start, at the last resting place
        before its destination, and its request into the destination has been held up
        for ``drive_on_after`` (docs/traffic.md, "Driving on")."""
        agv = self._agv
        after, plan, first = agv.config.drive_on_after, agv._plan, agv._first_try
        return (
            after is not None
            and plan is not None
            and agv._resume is None
            and agv.vehicle.speed == 0.0
            and agv.vehicle.s > agv._route_shift + 1e-6
            and requester.entry.end_s >= plan.length - 1e-9
            and first is not None
            and now - first[1] >= after
            and now >= self._no_drive_on_until
        )

    def drive_on(self) -> bool:
        """Drive on from the next point of the route to a waiting place (home, else a
        free rest point), then come back to the destination from there; False (and
        no new try for ``drive_on_after``) where there is no other way on."""
        agv = self._agv
        route, dest = agv._route, agv._dest
        assert route is not None
        assert dest is not None
        found = self.onward(route, dest)
        if found is None:
            assert agv.config.drive_on_after is not None
            self._no_drive_on_until = agv.node.now() + agv.config.drive_on_after
            return False
        self.take(*found, "drive_on")
        agv._resume = dest
        return True

    def must_detour(self, now: float, requester: Requester | CentralRequest) -> bool:
        """True if the AGV stands on its way, past its start and short of the last
        resting place before its destination, within a hull length of the route's next
        point, and its request has been held up for ``detour_after`` (docs/traffic.md,
        "Taking another way")."""
        agv = self._agv
        after, plan, first, route = (
            agv.config.detour_after,
            agv._plan,
            agv._first_try,
            agv._route,
        )
        vehicle = agv.vehicle
        if (
            after is None
            or plan is None
            or route is None
            or agv._resume is not None
            or vehicle.speed != 0.0
            or vehicle.s <= agv._route_shift + 1e-6
            or requester.entry.end_s >= plan.length - 1e-9
            or first is None
            or now - first[1] < after
            or now < self._no_detour_until
        ):
            return False
        ahead = self.next_point(route)
        if ahead >= len(route.points) - 1:
            return False
        return route.offsets[ahead] + agv._route_shift - vehicle.s <= agv.spec.length_m

    def detour(self) -> bool:
        """Take another way to the destination from the route's next point, one that
        drives neither the segment it was waiting to drive nor the one it stands on;
        False where there is none. Either way no new try for ``detour_after``."""
        agv = self._agv
        route, dest = agv._route, agv._dest
        assert route is not None
        assert dest is not None
        assert agv.config.detour_after is not None
        self._no_detour_until = agv.node.now() + agv.config.detour_after
        ahead = self.next_point(route)
        avoid = {route.segments[ahead], *route.segments[ahead - 1 : ahead]}
        if agv.ways is not None:
            avoid |= agv.ways.closed.segments
        try:
            onward = agv.layout.route_avoiding(route.points[ahead], dest, avoid)
        except NoRouteError:
            return False
        self.take(ahead, onward, "detour")
        return True

    def next_point(self, route: Route) -> int:
        """The index of the route's next point ahead of the vehicle (past the last
        point when the vehicle stands on it)."""
        agv = self._agv
        return route.index_at(agv.vehicle.s - agv._route_shift + 1e-6) + 1

    def take(self, ahead: int, onward: Route, resort: str) -> None:
        """Leave the route at its point ``ahead`` for ``onward`` (a last resort, counted
        as ``resort``): the lead piece is the rest of the way to that point, and the
        vehicle starts at its beginning, where it stands."""
        agv = self._agv
        route, vehicle = agv._route, agv.vehicle
        assert route is not None
        lead = vehicle.route.slice(vehicle.s, route.offsets[ahead] + agv._route_shift)
        path = Polyline([*lead.coords, *onward.polyline.coords])
        agv.routing.follow(onward, path, shift=lead.length, start_s=0.0)
        agv._dest = onward.end
        agv._stalled = False
        agv._first_try = None
        agv._advance = agv.config.advance_m
        agv._route_started_at = agv.node.now()
        if agv._on_last_resort is not None:
            agv._on_last_resort(resort)

    def onward(self, route: Route, dest: str) -> tuple[int, Route] | None:
        """The index of the route's next point and the way from there to a waiting
        place that does not pass ``dest``, or None."""
        agv = self._agv
        ahead = self.next_point(route)
        via = route.points[min(ahead, len(route.points) - 1)]
        if via == dest:
            return None  # already on the way into it: there is no other way on
        place: str | None = agv.home
        if place in (via, dest) and agv._relocate is not None:
            place = agv._relocate(agv)
            if place is not None:
                agv.home = place
        if place is None or place in (via, dest):
            return None
        try:
            onward = agv.way(via, place)
        except NoRouteError:
            return None
        return None if dest in onward.points else (ahead, onward)
