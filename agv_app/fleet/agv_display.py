"""What an AGV process shows the observer to draw its vehicle, and what the dashboard
shows of its node, over the observer's display session (:mod:`agv_app.fleet.display_feed`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from agv_app.fleet.display_feed import DISPLAY_ROLE, DisplayFeed
from agv_app.fleet.remote import roles_wire, sessions_wire, traffic_wire
from agv_app.geometry import Area, polygon_to_coords
from agv_app.vehicle.controller import AgvController
from agv_app.vehicle.service import loaded

__all__ = ["DisplayPublisher"]


def _area_coords(areas: list[Area]) -> list[list[list[float]]]:
    # Display and monitoring only: no safety margin, the observer never votes with it.
    return polygon_to_coords(Area.union_of(areas), margin_m=0.0)


class _AreaCoords:
    """``_area_coords`` of the last areas asked for, worked out again only when they
    change: the lock book hands out the same area objects until a lock or request moves,
    and the union of their polygons is most of a publication's cost."""

    __slots__ = ("_areas", "_coords")

    def __init__(self) -> None:
        self._areas: list[Area] = []
        self._coords: list[list[list[float]]] = []

    def __call__(self, areas: list[Area]) -> list[list[list[float]]]:
        known = self._areas
        if len(areas) != len(known) or any(a is not b for a, b in zip(areas, known, strict=True)):
            self._areas = list(areas)  # held, so no other object can take their ids
            self._coords = _area_coords(areas)
        return self._coords


def _route_ahead(agv: AgvController) -> list[list[float]]:
    """The vertices of the route still ahead (to centimetres), the last where it stops;
    empty at rest or failed. Changes only at a vertex or with a new route."""
    vehicle = agv.vehicle
    if agv.failed or vehicle.remaining() <= 1e-9:
        return []
    ahead = vehicle.route.slice(vehicle.s, vehicle.route.length).coords[1:]
    return [[round(x, 2), round(y, 2)] for x, y in ahead]


class DisplayPublisher:
    """Shows the observer what it needs to draw one AGV, and what the dashboard shows
    of its node (``agv_app.fleet.remote``), each only on change, over the observer's
    display session (:mod:`agv_app.fleet.display_feed`), not to every node that hears
    the AGV.

    Args:
        agv: the AGV component (its node plays the display role).
        min_move_m: show the pose again when the vehicle moved at least this far.
        traffic_interval_s: least time between two reports of the node's introspection
            (sessions, roles, traffic), which change with every request.
        shown: the state to show instead of the AGV's own (None from it: its own), e.g.
            ``charging`` (:meth:`~agv_app.fleet.charge_listener.ChargeListener.status`).
    """

    def __init__(
        self,
        agv: AgvController,
        *,
        min_move_m: float = 0.01,
        traffic_interval_s: float = 1.0,
        shown: Callable[[], str | None] | None = None,
    ) -> None:
        self.agv = agv
        self.shown = shown
        self.min_move_m = min_move_m
        self.traffic_interval_s = traffic_interval_s
        self.feed = DisplayFeed()
        self._next_traffic = -math.inf
        self._pose: tuple[float, float, float] | None = None
        self._locked = _AreaCoords()
        self._requested = _AreaCoords()
        agv.node.set_participant_factory(DISPLAY_ROLE, self.feed.reporter)
        self.feed.set("size", [agv.spec.length_m, agv.spec.width_m])

    def publish(self) -> None:
        """Show the pose, state and projections, and send what changed."""
        agv, feed = self.agv, self.feed
        if agv.failed:
            return
        pose = agv.vehicle.pose()
        heading = round(math.remainder(pose.heading_rad, math.tau), 3)
        last = self._pose
        if (
            last is None
            or math.hypot(pose.x - last[0], pose.y - last[1]) >= self.min_move_m
            or heading != last[2]
        ):
            self._pose = (pose.x, pose.y, heading)
            feed.set("position", [round(pose.x, 3), round(pose.y, 3)])
            feed.set("heading", heading)
        # The task with the state: the observer learns that the AGV set off with it
        # from one report, whatever the order of the property stream and the channel.
        feed.set("task", agv.node.properties.get("task"))
        by_battery = None if self.shown is None else self.shown()
        feed.set("state", by_battery or agv.display_status())
        speed = agv.vehicle.speed
        # Standing is exactly 0; any motion shows as at least 0.1 m/s.
        feed.set("speed", 0.0 if speed == 0.0 else max(0.1, round(speed, 1)))
        feed.set("held", agv.held)
        feed.set("in_service", agv.in_service)
        feed.set("loaded", loaded(agv))  # it cannot be sent home while loaded
        if agv.battery is not None:
            feed.set("battery", round(agv.battery.state_of_charge(agv.node.now()), 3))
        locks, request = agv.areas()
        feed.set("locked", self._locked(locks))
        feed.set("requested", self._requested([] if request is None else [request]))
        feed.set("route", _route_ahead(agv))
        self.publish_introspection()
        feed.flush()

    def publish_introspection(self) -> None:
        """Show the sessions, roles and traffic of the node, each on change, at most
        every ``traffic_interval_s``: what the dashboard shows of a node.

        Not the traffic while the AGV is at rest: its counters change with every frame
        it hears, its own reports included, so it would report every interval for as
        long as it stands. The dashboard shows a parked AGV's traffic as of when it
        parked."""
        node, feed = self.agv.node, self.feed
        now = node.now()
        if now >= self._next_traffic:
            self._next_traffic = now + self.traffic_interval_s
            feed.set("sessions", sessions_wire(node.sessions()))
            feed.set("roles", roles_wire(node.participations()))
            if not self.agv.at_rest:
                feed.set("traffic", traffic_wire(node.stats()))
