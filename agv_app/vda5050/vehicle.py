"""An AGV that drives the orders of a VDA 5050 master control, with the fleet's locks.

:class:`OrderAgv` is the :class:`~agv_app.vehicle.controller.AgvController` with an
:class:`~agv_app.vda5050.order.OrderBook`: at rest, it drives the order's base (its
released nodes, along the order's own edges) in stretches, and the controller's
collision and deadlock avoidance decide, as for any route, when it may move. A stretch
ends at the base's end, or at the first node whose actions stop the vehicle ('SOFT' or
'HARD' ones: a pick, a drop); there it stands until those actions have ended
(:class:`~agv_app.vda5050.actions.ActionBook`). It never drives into the horizon; with
only the horizon left it stands and waits for an update.

Without an order it stands where the last one left it. It still takes desk tasks
while it has no order (its ``status`` is ``busy`` during an order, so it bids for none),
and refuses an order while it carries a desk task.

Pausing brakes the vehicle to a standstill where it is and pauses the actions that may
pause. Cancelling ends the stretch at the first order node ahead that the vehicle can
still stop at without braking harder than its limit, drops the rest of the order, and
fails the actions that have not started (a pick or drop under way runs to its end).
A vehicle that drives off a charger stops charging.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from agv_app.geometry import Polyline
from agv_app.layout.elements import Route
from agv_app.traffic.central import CentralRequest
from agv_app.traffic.collision import Requester
from agv_app.traffic.deadlock import StopPlan
from agv_app.vda5050.actions import ActionBook
from agv_app.vda5050.charging import Battery, battery_of
from agv_app.vda5050.handling import LoadHandling
from agv_app.vda5050.order import OrderBook, OrderRejected, Outcome
from agv_app.vda5050.reports import MOBILE_ROBOT_NOT_AVAILABLE, OTHER_ORDER_ACTIVE, VdaError
from agv_app.vehicle.controller import AgvController
from agv_app.vehicle.kinematics import Vehicle

__all__ = ["INITIALIZE_TOLERANCE_M", "OrderAgv"]

_EPS_M = 1e-6

INITIALIZE_TOLERANCE_M = 0.1
"""How far an ``initializePosition`` pose may be from where the vehicle stands."""


class OrderAgv(AgvController):
    """An AGV component that also follows VDA 5050 orders.

    Takes the arguments of :class:`~agv_app.vehicle.controller.AgvController`, plus:

    Args:
        manufacturer: the vehicle's manufacturer in VDA 5050 messages.
        on_change: called (no arguments) when something the ``state`` shows changed:
            a node reached, an action's status, the order finished, paused, driving
            started or stopped, charging.
        on_order: called with ``(event, book)`` when an order is ``accepted``, and when
            it has ``finished`` or been ``cancelled`` (the vehicle idle again).
    """

    def __init__(
        self,
        *args: Any,
        manufacturer: str,
        on_change: Callable[[], None] | None = None,
        on_order: Callable[[str, OrderBook], None] | None = None,
        **kwargs: Any,
    ) -> None:
        self.orders: OrderBook | None = None
        self.paused = False
        self.on_change = on_change
        self.on_order = on_order
        self._stretch: list[str] = []
        self._stretch_s: list[float] = []
        self._cancelling = False
        self._open = False
        super().__init__(*args, **kwargs)
        self.battery: Battery = battery_of(self)
        self.handling = LoadHandling(
            self.layout, self.battery, handling_s=self.config.dwell, standing_at=self._standing_at
        )
        self.orders = OrderBook(
            self.layout,
            manufacturer,
            self.node_id,
            actions=ActionBook(self.handling),
            last_node_id=self.point,
        )

    @property
    def book_of_orders(self) -> OrderBook:
        """The order book (present once constructed)."""
        assert self.orders is not None
        return self.orders

    # -- what the state shows -----------------------------------------------------------

    @property
    def status(self) -> str:
        """``busy`` while an order or a desk task runs, else ``idle``."""
        if self.orders is not None and self.orders.active:
            return "busy"
        return super().status

    def display_status(self) -> str:
        """The controller's, and ``loading`` while a pick or drop runs."""
        if not self.failed and self.orders is not None:
            actions = self.orders.actions
            if actions.running("pick") or actions.running("drop"):
                return "loading"
        return super().display_status()

    @property
    def driving(self) -> bool:
        """True while the vehicle moves."""
        return self.vehicle.speed > 0.0

    @property
    def at_rest(self) -> bool:
        """True when the vehicle stands on a point with no route."""
        return self._dest is None and self.vehicle.speed == 0.0

    def _standing_at(self) -> str | None:
        return self.point if self.at_rest else None

    def _changed(self) -> None:
        if self.on_change is not None:
            self.on_change()

    # -- orders ---------------------------------------------------------------------------

    def receive_order(self, message: Any) -> Outcome:
        """Take an ``order`` message (see :meth:`OrderBook.receive`).

        Raises:
            OrderRejected: the order is invalid, or cannot be taken now (the vehicle
                carries a desk task, or has failed).
        """
        book = self.book_of_orders
        if self.failed:
            raise OrderRejected(
                VdaError(MOBILE_ROBOT_NOT_AVAILABLE, "the vehicle has failed: it takes no order")
            )
        if self.task is not None or self.pending_task is not None:
            raise OrderRejected(
                VdaError(OTHER_ORDER_ACTIVE, "the vehicle carries a task of the fleet's desk")
            )
        outcome = book.receive(
            message, at_rest=self.at_rest and not self._cancelling, now=self.node.now()
        )
        if outcome == "accepted":
            self._open = True
            if self.on_order is not None:
                self.on_order("accepted", book)
        if outcome != "duplicate":
            self._changed()
        return outcome

    def cancel_order(self) -> bool:
        """Cancel the order: stop at the next node the vehicle can stop at, drop the rest,
        fail the actions not started.

        Returns:
            False if there was no order to cancel.
        """
        book = self.book_of_orders
        if not book.active or book.cancelled:
            return False
        book.actions.cancel()
        book.cancelled = True
        self._cancelling = True
        if self._dest is None or not self._stretch:
            book.cancel()
        else:
            self._truncate_stretch()
        self._changed()
        return True

    @property
    def cancelling(self) -> bool:
        """True from ``cancel_order`` until the vehicle stands and no action runs."""
        return self._cancelling

    def pause(self) -> None:
        """``startPause``: brake to a standstill, pause the actions that may pause."""
        self.paused = True
        self.book_of_orders.actions.pause(self.node.now())
        self._changed()

    def resume(self) -> None:
        """``stopPause``: drive on, resume the paused actions."""
        self.paused = False
        self.book_of_orders.actions.resume(self.node.now())
        self._changed()

    def initialize_position(self, x: float, y: float, map_id: str, last_node_id: str) -> str | None:
        """``initializePosition``: confirm where the vehicle stands. The vehicle knows its
        pose; one that disagrees with it is refused, for the fleet's locks are where the
        vehicle is.

        Returns:
            Why the pose is refused (None: taken; ``lastNodeId`` is now ``last_node_id``).
        """
        if map_id != self.layout.name:
            return f"map {map_id!r} is unknown; the vehicle is on {self.layout.name!r}"
        point = self.layout.points.get(last_node_id)
        if point is None:
            return f"node {last_node_id!r} is not on the layout"
        if self.book_of_orders.active or not self.at_rest:
            return "the vehicle is not idle: it has an order, or drives"
        pose = self.vehicle.pose()
        for what, (px, py) in (("the pose", (x, y)), ("node " + repr(point.id), point.xy)):
            if math.dist((px, py), (pose.x, pose.y)) > INITIALIZE_TOLERANCE_M:
                return (
                    f"{what} is not where the vehicle stands ({pose.x:.2f}, {pose.y:.2f}); "
                    "a vehicle of the fleet is not moved by hand"
                )
        self.book_of_orders.stand_at(point.id)
        self._changed()
        return None

    def _truncate_stretch(self) -> None:
        """End the stretch at the first node at or past where full braking would stop."""
        vehicle = self.vehicle
        stop_s = vehicle.stopping_s()
        ahead = [k for k, node_s in enumerate(self._stretch_s) if node_s >= stop_s - _EPS_M]
        if not ahead or ahead[0] == len(self._stretch_s) - 1:
            return  # the stretch's end is the first place it can stop anyway
        k = ahead[0]
        cut = self._stretch_s[k]
        coords = [
            xy
            for xy, s in zip(vehicle.route.coords, vehicle.route.cumulative, strict=True)
            if s <= cut + _EPS_M
        ]
        self.vehicle = Vehicle(
            self.spec, Polyline(coords), s=min(vehicle.s, cut), speed_m_s=vehicle.speed
        )
        plan = self._plan
        zones = () if plan is None else tuple(z for z in plan.zones if z[0] < cut)
        self._plan = StopPlan(cut, zones)
        self._dest = self._stretch[k]
        self._stretch = self._stretch[: k + 1]
        self._stretch_s = self._stretch_s[: k + 1]

    # -- driving ----------------------------------------------------------------------------

    def _route_for(self, dest: str) -> Route:
        if self._stretch and self._stretch[0] == self.point and self._stretch[-1] == dest:
            return self.layout.route_through(self._stretch)
        return super()._route_for(dest)

    def _must_yield(self, now: float) -> bool:
        # The master control plans an order's path; the vehicle keeps to it.
        return not self._stretch and super()._must_yield(now)

    def _must_drive_on(self, now: float, requester: Requester | CentralRequest) -> bool:
        # The same: it waits on the order's path for as long as it takes.
        return not self._stretch and super()._must_drive_on(now, requester)

    def _must_detour(self, now: float, requester: Requester | CentralRequest) -> bool:
        # The same: no other way than the order's.
        return not self._stretch and super()._must_detour(now, requester)

    def step(self, dt: float) -> None:
        """Advance ``dt`` seconds: brake while paused, else drive as the controller does;
        then the order's progress and its actions."""
        if self.failed:
            return
        moving = self.driving
        if self.paused:
            vehicle = self.vehicle
            if vehicle.speed > 0.0:
                vehicle.step(dt, min(vehicle.stopping_s(), self.book.lock_end(default=vehicle.s)))
        else:
            super().step(dt)
        if self.driving and self.battery.charging:
            self.battery.stop_charging(self.node.now())  # off the charger
            self._changed()
        self._track()
        if moving != self.driving:
            self._changed()

    def _track(self) -> None:
        """Report the order nodes the vehicle has reached on its stretch, advance the
        actions, and tell when the order has ended."""
        book = self.book_of_orders
        now = self.node.now()
        s = self.vehicle.s
        while self._stretch and self._stretch_s and s >= self._stretch_s[0] - _EPS_M:
            node = self._stretch.pop(0)
            self._stretch_s.pop(0)
            if book.reached(node, now):
                self._changed()
        if book.actions.advance(now):
            self._changed()
        if self._cancelling and self.at_rest:
            if book.nodes or book.edges:
                self._stretch, self._stretch_s = [], []
                book.cancel()
                self._changed()
            if book.actions.idle:
                self._cancelling = False
                self._changed()
        if self._open and not book.active and not self._cancelling:
            self._open = False
            if self.on_order is not None:
                self.on_order("cancelled" if book.cancelled else "finished", book)

    def _idle(self, now: float) -> None:
        if self.paused:
            return
        if self.task is not None or self.pending_task is not None or self.phase != "home":
            super()._idle(now)
            return
        book = self.book_of_orders
        if book.reached(self.point, now):
            self._changed()
        if (
            not book.nodes
            or book.cancelled
            or book.base_end() is None
            or book.actions.blocks_driving
        ):
            return  # no order, cancelled, waiting for an update, or an action holds it here
        points = book.base_points()
        if len(points) < 2:
            return
        self._stretch = points
        self.routing.route_to(points[-1])
        if self._dest is None:
            self._stretch = []
            return
        route = self.layout.route_through(points)
        lead = self.vehicle.route.length - route.length
        self._stretch_s = [lead + o for o in route.offsets]
        self.publish()
        self._changed()
