"""The operator's orders to a fleet of AGV processes, as the observer's properties.

Every AGV process follows them from the observer alone: the stop and out of service
(``hold``, :mod:`agv_app.fleet.holding`), the closed parts of the floor (``closed``,
:mod:`agv_app.fleet.closed_listener`), requests to go home (``send_home``, answered
by each process's ``sent_home``, :mod:`agv_app.fleet.sending_home`) and, with batteries,
the charging orders (``charge``, answered by ``charged``, :mod:`agv_app.fleet.mesh_charging`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from agv_app.fleet.blocks import FloorBlocks
from agv_app.fleet.closed_listener import CLOSED_PROPERTY, closed_wire
from agv_app.fleet.holding import HOLD_PROPERTY, HoldOrders
from agv_app.fleet.mesh_charging import CHARGE_PROPERTY, CHARGED_PROPERTY, MeshCharging
from agv_app.fleet.mesh_watch import ObservedAgvs
from agv_app.fleet.parking import ParkingPlan
from agv_app.fleet.sending_home import SEND_HOME_PROPERTY, SENT_HOME_PROPERTY, SendHomeOrders
from agv_app.layout.graph import Layout
from agv_app.vehicle.battery import BatterySpec

__all__ = ["ANSWERS", "OperatorOrders"]

ANSWERS = (SENT_HOME_PROPERTY, CHARGED_PROPERTY)
"""The AGV processes' properties that answer an order (the observer listens to them)."""


class OperatorOrders:
    """What the operator told a fleet of AGV processes, and its publication.

    Args:
        layout: the floor plan.
        holds: the fleet's stop and out of service orders.
        publish: sets one of the observer's properties (nothing while it is not running).
        seen: the AGVs as the observer hears them.
    """

    def __init__(
        self,
        layout: Layout,
        holds: HoldOrders,
        publish: Callable[[str, object], None],
        seen: ObservedAgvs,
    ) -> None:
        self._holds = holds
        self._publish = publish
        self._seen = seen
        self.blocks = FloorBlocks(
            layout, on_change=lambda ways: publish(CLOSED_PROPERTY, closed_wire(ways))
        )
        """The parts of the floor the operator closed."""
        self.homeward = SendHomeOrders()
        """Requests to go home the AGV processes have not answered yet."""
        self.charging: MeshCharging | None = None
        """The charging orders (None: no batteries, :meth:`charge`)."""

    def charge(
        self, spec: BatterySpec | None, parking: ParkingPlan, agv_ids: Sequence[str]
    ) -> MeshCharging | None:
        """Charge the AGVs ``agv_ids`` (homes: ``parking.homes``) as ``spec`` says; the
        control's side of it (None: no ``spec``, or no AGVs of ours to charge)."""
        if spec is not None and agv_ids:
            homes = dict(zip(agv_ids, parking.homes, strict=True))
            self.charging = MeshCharging(spec, parking, homes, self._publish)
        return self.charging

    def wire(self) -> dict[str, object]:
        """Every order, by the observer's property that carries it."""
        return {
            HOLD_PROPERTY: self._holds.wire(),
            CLOSED_PROPERTY: closed_wire(self.blocks.ways),
            SEND_HOME_PROPERTY: self.homeward.wire(),
            **({} if self.charging is None else {CHARGE_PROPERTY: self.charging.wire()}),
        }

    def publish_holds(self) -> None:
        """Publish the stop and out of service orders as they are now."""
        self._publish(HOLD_PROPERTY, self._holds.wire())

    def send_home(self, vehicle_id: str) -> None:
        """Ask the AGV process to go home (it acts once, as it hears it).

        Raises:
            ValueError: it failed, or reports a load on board.
        """
        if vehicle_id in self._seen.roster.failed():
            raise ValueError(f"{vehicle_id} has failed")
        if (self._seen.view(vehicle_id) or {}).get("loaded") is True:
            raise ValueError(f"{vehicle_id} is loaded: it delivers its load first")
        self.homeward.ask(vehicle_id)
        self._publish(SEND_HOME_PROPERTY, self.homeward.wire())

    def answer(self, node_id: str, name: str, value: Any) -> None:
        """An AGV process's answer (one of :data:`ANSWERS`): drop what it acted on."""
        if name == SENT_HOME_PROPERTY and self.homeward.answered(node_id, value):
            self._publish(SEND_HOME_PROPERTY, self.homeward.wire())
        elif name == CHARGED_PROPERTY and self.charging is not None:
            self.charging.answer(node_id, value)
