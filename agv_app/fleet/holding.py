"""An operator's stop: which vehicles are told to stand, and how a vehicle hears it.

What was asked is kept in :class:`HoldOrders`: the whole fleet stopped, and single
vehicles stopped on their own. A vehicle is held while either says so
(:meth:`HoldOrders.held`). The fleet acts on it:

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

from agv_app.fleet.view import OBSERVER_ID
from objectplaces import RoleActivator

__all__ = ["HOLD_PROPERTY", "HoldListener", "HoldOrders", "Holdable", "held_in"]

HOLD_PROPERTY = "hold"
"""The observer's property: ``[fleet stopped, [vehicle ids stopped on their own]]``."""


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


class HoldOrders:
    """What the operator asked: the fleet stopped, and vehicles stopped on their own."""

    def __init__(self) -> None:
        self.fleet = False
        """True between a fleet stop and a fleet resume."""
        self.vehicles: set[str] = set()
        """Vehicles stopped on their own, by id."""

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

    def wire(self) -> list[Any]:
        """The form the observer publishes as :data:`HOLD_PROPERTY`."""
        return [self.fleet, sorted(self.vehicles)]


def held_in(value: Any, vehicle_id: str) -> bool | None:
    """Whether the wire form ``value`` holds ``vehicle_id``; None if it is malformed."""
    if not (isinstance(value, list | tuple) and len(value) == 2):
        return None
    fleet, vehicles = value
    if not isinstance(fleet, bool) or not isinstance(vehicles, list | tuple):
        return None
    return fleet or vehicle_id in vehicles


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
        self.control_id = control_id
        self.refused = 0
        """Hold properties from another node than the control, or malformed, ignored."""
        node.register_node_property_observer(self._property, names=(HOLD_PROPERTY,))
        told = node.view().get(control_id, {}).get(HOLD_PROPERTY)
        if told is not None:
            self._property(control_id, HOLD_PROPERTY, told)

    def _property(self, node_id: str, name: str, value: Any) -> None:
        if node_id != self.control_id:
            self.refused += 1
            return
        held = held_in(value, self.agv.node_id)
        if held is None:
            self.refused += 1
        elif held:
            self.agv.hold()
        else:
            self.agv.release()
