"""An operator's orders to an AGV: hold and release, out of service and back, and the
state the dashboard shows (``display_status``).

The :class:`~agv_app.vehicle.controller.AgvController` owns one :class:`Operations`;
the state it sets (held, in service) is the controller's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from agv_app.geometry import Polyline

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = ["Operations"]


class Operations:
    """An operator's orders to one AGV (its controller's state, this job's logic).

    Args:
        agv: the controller the orders go to.
    """

    def __init__(self, agv: AgvController) -> None:
        self._agv = agv
        self._held_route: Polyline | None = None
        self._held_s = 0.0
        """While held: the route the vehicle rests on and the arc length it rests at."""

    def hold(self) -> None:
        """Brake to a standstill within the braking distance and stand there, locks kept.

        The vehicle's limit becomes the point where it comes to rest braking now (never
        past the end of its locks): it brakes as it would for any stop, asks for no
        floor and sets off for nothing until :meth:`release`; the locks it stands in
        stay its own. It bids for no task meanwhile.
        """
        agv = self._agv
        if not agv._held:
            agv._held = True
            self._held_route = None

    def release(self) -> None:
        """Drive on after :meth:`hold`: every order goes on where it stood."""
        agv = self._agv
        agv._held = False
        self._held_route = None

    def held_limit(self) -> float:
        """The arc length the held vehicle rests at: where it stopped braking at the
        hold, or, on a route set since (only ever while standing), where it stands."""
        agv = self._agv
        vehicle = agv.vehicle
        if self._held_route is not vehicle.route:
            self._held_route = vehicle.route
            self._held_s = vehicle.stopping_s()
        return self._held_s

    def display_status(self) -> str:
        """A finer state for the dashboard: idle, driving, waiting, loading, stopping or
        stopped (held by the operator), out-of-service (parked, taking no task) or
        failed."""
        agv = self._agv
        if agv.failed:
            return "failed"
        if agv._held:
            return "stopped" if agv.vehicle.speed == 0.0 else "stopping"
        if not agv.in_service and agv._dest is None and agv.task is None:
            return "out-of-service"
        if agv.phase in ("at_pick", "at_drop") or agv.node.now() < agv._hold_until:
            return "loading"
        if agv.blocked_to is not None or (agv._dest is not None and agv.vehicle.speed == 0.0):
            return "waiting"
        if agv._dest is not None:
            return "driving"
        return "idle"
