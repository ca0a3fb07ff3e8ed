"""An operator's stop: which vehicles are told to stand, and how a vehicle hears it.

What was asked is kept in :class:`HoldOrders`: the whole fleet stopped, single
vehicles stopped on their own, and vehicles out of service (they hand back a task they
have not loaded, deliver a loaded one, park at home and take no more:
:mod:`agv_app.vehicle.service`). A vehicle is held while the fleet's stop or its
own says so (:meth:`HoldOrders.held`). The fleet acts on it:

* the simulated fleet holds its controllers directly
  (:meth:`~agv_app.vehicle.controller.AgvController.hold`);
* a fleet of AGV processes publishes it as the observer's property ``hold``
  (:data:`HOLD_PROPERTY`, the wire form of :meth:`HoldOrders.wire`), and every AGV
  process follows it with a :class:`HoldListener`. The observer has no position, so
  the property reaches every node, as the relay of failed AGVs does
  (:mod:`agv_app.traffic.stale_relay`), and a vehicle that joins later hears it with
  the observer's other properties.

Only the control identity may stop a vehicle: a listener takes the property from the
node :data:`~agv_app.fleet.view.OBSERVER_ID` alone, and a node's id is the common name
of its certificate (the mesh refuses a hello that names another id, Zenoh's ACL lets a
member put on its own keys only; docs/security.md), which only the control host holds.
The same property published by any other node is ignored and counted.

A held vehicle brakes to a standstill within its braking distance and stands there
with its locks; what it reports (its state ``stopping`` then ``stopped``, its speed) is
what the dashboard shows, never what was asked.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any, Protocol

from agv_app.fleet.control_word import ControlWord
from agv_app.fleet.view import OBSERVER_ID
from objectplaces import RoleActivator

__all__ = ["HOLD_PROPERTY", "HoldListener", "HoldOrders", "Holdable", "held_in", "in_service_in"]

HOLD_PROPERTY = "hold"
"""The observer's property: ``[fleet stopped, [vehicle ids stopped on their own],
[vehicle ids out of service]]``."""


class Holdable(Protocol):
    """What a listener holds and releases: an AGV component."""

    @property
    def node_id(self) -> str:
        """Its node's id."""
        ...

    @property
    def held(self) -> bool:
        """True while held."""
        ...

    def hold(self) -> None:
        """Brake to a standstill and stand, locks kept."""
        ...

    def release(self) -> None:
        """Drive on."""
        ...

    @property
    def in_service(self) -> bool:
        """False while out of service."""
        ...

    def take_out_of_service(self) -> None:
        """Hand back a task not loaded (deliver a loaded one), park at home, take no more."""
        ...

    def return_to_service(self) -> None:
        """Take tasks again."""
        ...


class HoldOrders:
    """What the operator asked: the fleet stopped, and vehicles stopped on their own."""

    def __init__(self) -> None:
        self.fleet = False
        """True between a fleet stop and a fleet resume."""
        self.vehicles: set[str] = set()
        """Vehicles stopped on their own, by id."""
        self.out_of_service: set[str] = set()
        """Vehicles out of service, by id."""

    def stop(self, vehicle_ids: Collection[str] | None = None) -> None:
        """Stop ``vehicle_ids``, or the whole fleet (None)."""
        if vehicle_ids is None:
            self.fleet = True
        else:
            self.vehicles.update(vehicle_ids)

    def resume(self, vehicle_ids: Collection[str] | None = None) -> None:
        """Resume ``vehicle_ids``, or the fleet (None: vehicles stopped on their own
        stay stopped).

        Raises:
            ValueError: a vehicle is to resume while the whole fleet is stopped.
        """
        if vehicle_ids is None:
            self.fleet = False
            return
        if self.fleet:
            raise ValueError("the whole fleet is stopped: resume the fleet first")
        self.vehicles.difference_update(vehicle_ids)

    def held(self, vehicle_id: str) -> bool:
        """Whether ``vehicle_id`` is told to stand."""
        return self.fleet or vehicle_id in self.vehicles

    def in_service(self, vehicle_id: str) -> bool:
        """Whether ``vehicle_id`` takes tasks."""
        return vehicle_id not in self.out_of_service

    def set_service(self, vehicle_ids: Collection[str], *, in_service: bool) -> None:
        """Take ``vehicle_ids`` out of service, or bring them back."""
        if in_service:
            self.out_of_service.difference_update(vehicle_ids)
        else:
            self.out_of_service.update(vehicle_ids)

    def wire(self) -> list[Any]:
        """The form the observer publishes as :data:`HOLD_PROPERTY`."""
        return [self.fleet, sorted(self.vehicles), sorted(self.out_of_service)]


def _lists(value: Any) -> tuple[bool, Any, Any] | None:
    if not (isinstance(value, list | tuple) and len(value) in (2, 3)):
        return None
    fleet, vehicles, *rest = value
    out = rest[0] if rest else ()
    if not isinstance(fleet, bool) or not all(isinstance(v, list | tuple) for v in (vehicles, out)):
        return None
    return fleet, vehicles, out


def held_in(value: Any, vehicle_id: str) -> bool | None:
    """Whether the wire form ``value`` holds ``vehicle_id``; None if it is malformed."""
    lists = _lists(value)
    return None if lists is None else lists[0] or vehicle_id in lists[1]


def in_service_in(value: Any, vehicle_id: str) -> bool | None:
    """Whether the wire form ``value`` keeps ``vehicle_id`` in service; None if malformed."""
    lists = _lists(value)
    return None if lists is None else vehicle_id not in lists[2]


class HoldListener:
    """An AGV's ear for the control's stop: holds and releases ``agv`` as the observer's
    :data:`HOLD_PROPERTY` says, and nobody else's.

    Args:
        node: the AGV's node.
        agv: its component.
        control_id: the only node whose word counts (the observer).
    """

    def __init__(
        self, node: RoleActivator, agv: Holdable, *, control_id: str = OBSERVER_ID
    ) -> None:
        self.agv = agv
        self.word = ControlWord(node, HOLD_PROPERTY, self._heard, control_id=control_id)

    @property
    def refused(self) -> int:
        """Hold properties from another node than the control, or malformed, ignored."""
        return self.word.refused

    def _heard(self, value: Any) -> bool:
        agv = self.agv
        held = held_in(value, agv.node_id)
        in_service = in_service_in(value, agv.node_id)
        if held is None or in_service is None:
            return False
        if held:
            agv.hold()
        else:
            agv.release()
        if in_service:
            agv.return_to_service()
        else:
            agv.take_out_of_service()
        return True
