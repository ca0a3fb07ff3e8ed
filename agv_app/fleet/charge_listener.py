"""An AGV process's battery: it drains, follows the control's charging orders, charges
on the granted charger, and stops at 0 % (the control's side:
:mod:`agv_app.fleet.mesh_charging`).

:class:`ServiceGate` stands between the operator's orders
(:class:`~agv_app.fleet.holding.HoldListener`) and the AGV: the AGV takes tasks while
the operator keeps it in service and it is not due for a charge, and an empty one stays
held whatever the operator says. :class:`ChargeListener` takes the observer's
``charge`` property from the observer alone, as the other listeners do: ``due`` takes
the AGV out of service for tasks (it hands back a task it has not loaded and delivers a
loaded one), ``charge`` makes the charger its home, so it drives there as it drives
home; standing on it with no order, its battery charges up to ``charge_to``, and it
publishes ``charged``; ``rest`` makes the rest point its home and brings it back to
work. At 0 % it holds where it stands and shows ``empty``.
"""

from __future__ import annotations

from typing import Any

from agv_app.fleet.chargers import on_charger
from agv_app.fleet.control_word import ControlWord
from agv_app.fleet.mesh_charging import CHARGE_PROPERTY, CHARGED_PROPERTY, order_in
from agv_app.fleet.view import OBSERVER_ID
from agv_app.vehicle.battery import SimBattery
from agv_app.vehicle.battery_drain import BatteryDrain
from agv_app.vehicle.controller import AgvController
from agv_app.vehicle.service import take_out_of_service
from objectplaces import RoleActivator

__all__ = ["ChargeListener", "ServiceGate"]


class ServiceGate:
    """The AGV as the operator's stop sees it (a ``Holdable``), with the battery's word
    on top: out of service while due for a charge, held for good once empty.

    Args:
        agv: the AGV component.
    """

    def __init__(self, agv: AgvController) -> None:
        self.agv = agv
        self.operator_in_service = True
        """What the operator last said."""
        self.due = False
        """True from a ``due`` or ``charge`` order until the ``rest`` order."""
        self.empty = False
        """True once the battery ran empty."""

    @property
    def node_id(self) -> str:
        """The AGV's node id."""
        return self.agv.node_id

    @property
    def held(self) -> bool:
        """True while the AGV is held."""
        return self.agv.held

    def hold(self) -> None:
        """Hold the AGV."""
        self.agv.hold()

    def release(self) -> None:
        """Release the AGV, unless it ran empty."""
        if not self.empty:
            self.agv.release()

    @property
    def in_service(self) -> bool:
        """What the operator last said of service."""
        return self.operator_in_service

    def take_out_of_service(self) -> None:
        """The operator takes the AGV out of service."""
        self.operator_in_service = False
        self.agv.take_out_of_service()

    def return_to_service(self) -> None:
        """The operator brings the AGV back: it takes tasks unless due or empty."""
        self.operator_in_service = True
        if not (self.due or self.empty):
            self.agv.return_to_service()

    def set_due(self, due: bool) -> None:
        """Due for a charge (hand back an unloaded task, take no more), or not."""
        if due and not self.due:
            take_out_of_service(self.agv)
        self.due = due
        if not due and self.operator_in_service and not self.empty:
            self.agv.return_to_service()

    def run_empty(self) -> None:
        """The battery is empty: stop where it stands, locks kept, take no task."""
        self.empty = True
        self.agv.in_service = False
        self.agv.hold()


class ChargeListener:
    """An AGV process's battery and its ear for the control's charging orders (the
    module docstring). Call :meth:`step` at every control step.

    Args:
        node: the AGV's node.
        agv: its component (with a :class:`~agv_app.vehicle.battery.SimBattery`).
        gate: what stands between the operator's orders and the AGV.
        control_id: the only node whose word counts (the observer).
    """

    def __init__(
        self,
        node: RoleActivator,
        agv: AgvController,
        gate: ServiceGate,
        *,
        control_id: str = OBSERVER_ID,
    ) -> None:
        self.node = node
        self.agv = agv
        self.gate = gate
        self.drain = BatteryDrain(agv)
        self.order: tuple[int, str, str] | None = None
        """The last order followed: ``(number, kind, point)``."""
        self._last_heard: tuple[int, str, str] | None = None
        self._charged: int | None = None
        self.word = ControlWord(node, CHARGE_PROPERTY, self._heard, control_id=control_id)

    @property
    def refused(self) -> int:
        """Charging orders from another node than the control, ignored."""
        return self.word.refused

    def status(self) -> str | None:
        """``empty``, ``charging`` or ``to-charger`` (due, with no task on board) to show
        instead of the AGV's own status; None: its own."""
        battery = self.agv.battery
        if self.gate.empty:
            return "empty"
        if isinstance(battery, SimBattery) and battery.charging:
            return "charging"
        agv = self.agv
        if self.gate.due and agv.task is None and agv.pending_task is None:
            return "to-charger"
        return None

    def step(self, dt: float) -> float | None:
        """Drain, or charge on the granted charger, for the step of ``dt`` that just
        ended; stop at 0 %. The state of charge after (None: no battery)."""
        agv, gate = self.agv, self.gate
        battery = agv.battery
        if not isinstance(battery, SimBattery) or agv.failed:
            return None
        now = self.node.now()
        order = self.order
        if battery.charging:
            charged = battery.state_of_charge(now)
            if charged >= battery.spec.charge_to or not battery.charging:
                battery.stop_charging(now)
                if order is not None and order[1] == "charge":
                    self._report(order[0])
            return charged
        if gate.empty:
            return 0.0
        level = self.drain.step(dt)
        if level is None:
            return None
        if level <= 0.0:
            gate.run_empty()
        elif (
            order is not None
            and order[1] == "charge"
            and order[0] != self._charged
            and on_charger(agv)
        ):
            if level < battery.spec.charge_to:
                battery.start_charging(now)
            else:
                self._report(order[0])  # full already: nothing to charge
        return level

    def _report(self, number: int) -> None:
        """Full: tell the control, which frees the charger."""
        self._charged = number
        self.node.update_node_property(CHARGED_PROPERTY, number)

    def _heard(self, value: Any) -> bool:
        order = order_in(value, self.node.node_id)
        if order is not None and order != self._last_heard:
            self._last_heard = order
            # Not from inside the view's update: handing back publishes properties.
            self.node.call_later(0.0, lambda: self._follow(order))
        return True

    def _follow(self, order: tuple[int, str, str]) -> None:
        self.order = order
        _, kind, point = order
        if kind == "rest":
            battery = self.agv.battery
            if isinstance(battery, SimBattery):
                battery.stop_charging(self.node.now())
            self.agv.home = point
            self.gate.set_due(False)
            return
        self.gate.set_due(True)
        if kind == "charge":
            self.agv.home = point  # it drives there as it drives home, once its order is done
