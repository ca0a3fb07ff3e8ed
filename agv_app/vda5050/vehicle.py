"""An AGV that drives the orders of a VDA 5050 master control, with the fleet's locks.

:class:`OrderAgv` is the :class:`~agv_app.vehicle.controller.AgvController` with an
:class:`~agv_app.vda5050.order.OrderBook`: at rest, it drives the order's base (its
released nodes, along the order's own edges) in one stretch, and the controller's
collision and deadlock avoidance decide, as for any route, when it may move. It never
drives into the horizon; with only the horizon left it stands and waits for an update.

Without an order it stands where the last one left it. It still takes desk tasks
while it has no order (its ``status`` is ``busy`` during an order, so it bids for none),
and refuses an order while it carries a desk task.

Pausing brakes the vehicle to a standstill where it is (``startPause``, ``stopPause``).
Cancelling ends the stretch at the first order node ahead that the vehicle can still
stop at without braking harder than its limit, and drops the rest of the order.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from agv_app.geometry import Polyline
from agv_app.layout.elements import Route
from agv_app.traffic.central import CentralRequest
from agv_app.traffic.collision import Requester
from agv_app.traffic.deadlock import StopPlan
from agv_app.vda5050.order import OrderBook, OrderRejected, Outcome, VdaError
from agv_app.vehicle.controller import AgvController
from agv_app.vehicle.kinematics import Vehicle

__all__ = ["OrderAgv"]

_EPS_M = 1e-6


class OrderAgv(AgvController):
    """An AGV component that also follows VDA 5050 orders.

    Takes the arguments of :class:`~agv_app.vehicle.controller.AgvController`, plus:

    Args:
        manufacturer: the vehicle's manufacturer in VDA 5050 messages.
        on_change: called (no arguments) when something the ``state`` shows changed:
            a node reached, the order finished, paused, driving started or stopped.
    """

    def __init__(
        self,
        *args: Any,
        manufacturer: str,
        on_change: Callable[[], None] | None = None,
        **kwargs: Any,
    ) -> None:
        self.orders: OrderBook | None = None
        self.paused = False
        self.on_change = on_change
        self._stretch: list[str] = []
        self._stretch_s: list[float] = []
        self._cancelling = False
        super().__init__(*args, **kwargs)
        self.orders = OrderBook(self.layout, manufacturer, self.node_id, last_node_id=self.point)

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

    @property
    def driving(self) -> bool:
        """True while the vehicle moves."""
        return self.vehicle.speed > 0.0

    @property
    def at_rest(self) -> bool:
        """True when the vehicle stands on a point with no route."""
        return self._dest is None and self.vehicle.speed == 0.0

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
        if self.failed or self.task is not None or self.pending_task is not None:
            why = "has failed" if self.failed else "carries a task of the fleet's desk"
            raise OrderRejected(VdaError("orderError", f"the vehicle {why}"))
        outcome = book.receive(message, at_rest=self.at_rest and not self._cancelling)
        if outcome != "duplicate":
            self._changed()
        return outcome

    def cancel_order(self) -> bool:
        """Cancel the order: stop at the next node the vehicle can stop at, drop the rest.

        Returns:
            False if there was no order to cancel.
        """
        book = self.book_of_orders
        if not book.active:
            return False
        if self._dest is None or not self._stretch:
            book.cancel()
            self._changed()
            return True
        self._cancelling = True
        self._truncate_stretch()
        return True

    @property
    def cancelling(self) -> bool:
        """True from ``cancel_order`` until the vehicle stands."""
        return self._cancelling

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
        """Advance ``dt`` seconds: brake while paused, else drive as the controller does."""
        if self.failed:
            return
        moving = self.driving
        if self.paused:
            vehicle = self.vehicle
            if vehicle.speed > 0.0:
                vehicle.step(dt, min(vehicle.stopping_s(), self.book.lock_end(default=vehicle.s)))
        else:
            super().step(dt)
        self._track()
        if moving != self.driving:
            self._changed()

    def _track(self) -> None:
        """Report the order nodes the vehicle has reached on its stretch."""
        book = self.book_of_orders
        s = self.vehicle.s
        while self._stretch and self._stretch_s and s >= self._stretch_s[0] - _EPS_M:
            node = self._stretch.pop(0)
            self._stretch_s.pop(0)
            if book.reached(node):
                self._changed()
        if self._cancelling and self.at_rest:
            self._cancelling = False
            self._stretch, self._stretch_s = [], []
            book.cancel()
            self._changed()

    def _idle(self, now: float) -> None:
        if self.paused:
            return
        if self.task is not None or self.pending_task is not None or self.phase != "home":
            super()._idle(now)
            return
        book = self.book_of_orders
        book.reached(self.point)
        if not book.active or book.base_end() is None:
            return  # no order, or waiting for an update: stand where we are
        points = book.base_points()
        self._stretch = points
        self._route_to(points[-1])
        if self._dest is None:
            self._stretch = []
            return
        route = self.layout.route_through(points)
        lead = self.vehicle.route.length - route.length
        self._stretch_s = [lead + o for o in route.offsets]
        self.publish()
        self._changed()
