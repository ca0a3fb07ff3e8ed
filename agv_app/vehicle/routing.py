"""How an AGV sets out on a route: the lead piece, the first lock, the stop plan.

The :class:`~agv_app.vehicle.controller.AgvController` owns one :class:`Routing`; the
route, plan and locks it sets are the controller's.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from agv_app.geometry import Polyline
from agv_app.layout.elements import NoRouteError, Route
from agv_app.traffic.deadlock import StopPlan, followable_segments, merge_branches, turn_offs
from agv_app.traffic.lockbook import LockEntry
from agv_app.vehicle.closures import wait_for_way

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = ["LEAD_M", "Routing"]

LEAD_M = 0.01
"""A short piece in the old heading before a route, so the first turn is swept and locked."""


class Routing:
    """Sets one AGV out on its routes (its controller's state, this job's logic).

    Args:
        agv: the controller whose vehicle it drives.
    """

    def __init__(self, agv: AgvController) -> None:
        self._agv = agv
        layout, spec, config = agv.layout, agv.spec, agv.config
        self._followable = followable_segments(layout) if config.direction_claims else frozenset()
        self._merges = merge_branches(layout) if config.clear_merges else frozenset()
        self._turns = turn_offs(layout) if config.clear_turn_offs else frozenset()
        # The hull clear of the lane a branch joins: half its length plus half a width.
        self._merge_box_m = (spec.length_m + spec.width_m) / 2

    def route_to(self, dest: str | None) -> bool:
        """Start driving to point ``dest`` (None: stay), from the point we rest on.

        Returns:
            Whether the AGV drives off: False for None or the point it rests on.
        """
        agv = self._agv
        agv._dest = dest
        agv.blocked_to = None
        agv._stalled = False
        agv._first_try = None
        agv._route_started_at = agv.node.now()
        if dest is None or dest == agv.point:
            agv._plan = None
            agv._dest = None
            return False
        try:
            route = agv._route_for(dest)
        except NoRouteError:
            if agv.ways is None:
                raise
            return wait_for_way(agv, dest)
        agv._route = route
        heading = agv.vehicle.pose().heading_rad
        ahead = route.polyline.piece_heading(0)
        if abs(math.remainder(ahead - heading, math.tau)) > math.pi / 2:
            # The hull is symmetric: facing backwards is the same rectangle, so the
            # vehicle drives off the other way instead of turning on the spot.
            heading += math.pi
        x0, y0 = route.polyline.start
        lead = (x0 - LEAD_M * math.cos(heading), y0 - LEAD_M * math.sin(heading))
        path = Polyline([lead, *route.polyline.coords])
        # Start exactly on the lead piece's end (its rounded length, not LEAD_M): there
        # the vehicle still faces the old way, so its first lock is the hull it stands
        # in and the first request sweeps the turn.
        self.follow(route, path, shift=path.cumulative[1], start_s=path.cumulative[1])
        return True

    def follow(self, route: Route, path: Polyline, *, shift: float, start_s: float) -> None:
        """Drive ``route`` along ``path``, which has a lead piece of ``shift`` metres
        before it, from ``start_s``: the first lock is the hull the vehicle stands in,
        and the claims it holds are kept until that lock moves."""
        agv = self._agv
        standing = agv.book.claims()
        agv.vehicle.new_route(path, s=start_s)
        agv._route = route
        agv._route_shift = shift
        agv._plan = self.plan_for(route).shifted(shift)
        agv._key += 1
        agv.book.set_locks(LockEntry(agv._key, agv.vehicle.s, agv.vehicle.hull(), claims=standing))
        agv._released_at_s = agv.vehicle.s

    def plan_for(self, route: Route) -> StopPlan:
        """The resting places of ``route`` under this AGV's rules."""
        agv = self._agv
        return StopPlan.for_route(
            agv.layout,
            route,
            clearance_m=agv.clearance_m,
            followable=self._followable,
            merges=self._merges,
            merge_box_m=self._merge_box_m,
            turns=self._turns,
            way_out_reach_m=agv.config.advance_m if agv.config.keep_way_out else None,
        )
