"""Charging in a fleet of AGV processes: the control decides, each process follows.

The control (:class:`~agv_app.fleet.mesh.MeshFleet`) plays the part the simulated
fleet's :class:`~agv_app.fleet.chargers.Chargers` plays, by the same rule
(:class:`~agv_app.fleet.charge_rule.ChargeQueue`): from the state of charge each AGV
process reports (``battery``, its display) it decides who must charge, grants chargers
first come first served in its :class:`~agv_app.fleet.parking.ParkingPlan`, and
publishes its orders as the observer's property ``charge`` (:data:`CHARGE_PROPERTY`):
``[[vehicle id, number, kind, point], ...]``, one entry per vehicle, numbers counting
up. ``due``: it takes no more tasks; ``charge``: its home becomes the charger ``point``;
``rest``: charged, its home becomes the rest point ``point`` and it takes tasks again.
A process answers a ``charge`` order, once full, with its property ``charged``
(:data:`CHARGED_PROPERTY`, the order's number); the control then frees the charger and
orders ``rest``. A process that reports ``empty`` (it stopped at 0 %) raises an alarm
(:attr:`MeshCharging.alarms`). Each process follows with a
:class:`~agv_app.fleet.charge_listener.ChargeListener`, from the observer alone.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

from agv_app.fleet.charge_rule import ChargeQueue
from agv_app.fleet.parking import ParkingPlan
from agv_app.vehicle.battery import BatterySpec

__all__ = ["CHARGED_PROPERTY", "CHARGE_PROPERTY", "KINDS", "MeshCharging", "order_in"]

CHARGE_PROPERTY = "charge"
"""The observer's property: ``[[vehicle id, number, kind, point], ...]``."""

CHARGED_PROPERTY = "charged"
"""An AGV's property: the number of the last ``charge`` order it charged for."""

KINDS = ("due", "charge", "rest")
"""The kinds of a charging order."""


def order_in(value: Any, vehicle_id: str) -> tuple[int, str, str] | None:
    """The order for ``vehicle_id`` in the wire form ``value``: ``(number, kind,
    point)`` (None: none, or malformed)."""
    if not isinstance(value, list | tuple):
        return None
    for entry in value:
        if not (isinstance(entry, list | tuple) and len(entry) == 4 and entry[0] == vehicle_id):
            continue
        _, number, kind, point = entry
        whole = isinstance(number, int) and not isinstance(number, bool)
        if whole and kind in KINDS and isinstance(point, str):
            return number, kind, point
    return None


def _level(value: Any) -> float | None:
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


class MeshCharging:
    """The control's side of charging a fleet of AGV processes (the module docstring).

    Args:
        spec: the AGVs' battery (its thresholds; the processes run the same).
        parking: the fleet's parking plan; every AGV owns its home there.
        homes: each AGV's home at start, by id.
        publish: sets one of the observer's properties.
    """

    def __init__(
        self,
        spec: BatterySpec,
        parking: ParkingPlan,
        homes: Mapping[str, str],
        publish: Callable[[str, object], None],
    ) -> None:
        for agv_id, home in homes.items():
            parking.claim(agv_id, home)
        self.rule = ChargeQueue(spec, parking, homes)
        """Who must charge, the queue and the grants (shared with the simulated fleet)."""
        self.homes = dict(homes)
        """Each AGV's home as the control last gave it."""
        self.alarms = self.rule.alarms
        """``(time, AGV id, message)`` for every AGV that ran empty."""
        self.orders: dict[str, tuple[int, str, str]] = {}
        """Each vehicle's last order: ``(number, kind, point)``."""
        self._publish = publish
        self._count = 0
        self._refilled: set[str] = set()  # charged: its last report may predate the charge
        self._layout = parking.layout

    def wire(self) -> list[list[Any]]:
        """The form the observer publishes as :data:`CHARGE_PROPERTY`."""
        return [[v, *order] for v, order in sorted(self.orders.items())]

    def tick(self, views: Iterable[tuple[str, Mapping[str, Any]]], now: float) -> None:
        """Take what the AGVs report (state of charge, ``charging``, ``empty``); order
        the ones due and grant free chargers."""
        rule, changed = self.rule, False
        positions: dict[str, Any] = {}
        for agv_id, props in views:
            if agv_id not in self.homes:
                continue  # not one of ours (joined from elsewhere): no home to give
            positions[agv_id] = props.get("position")
            state, level = props.get("state"), _level(props.get("battery"))
            if state == "empty" or level == 0.0:
                rule.ran_empty(agv_id, now)
                continue
            if state == "charging":
                rule.arrived(agv_id)
            if level is None:
                continue
            if agv_id in self._refilled:
                if level < rule.spec.charge_below:
                    continue
                self._refilled.discard(agv_id)
            rule.note(agv_id, level, now)
            if rule.state[agv_id] == "needs" and self.orders.get(agv_id, (0, ""))[1] != "due":
                self._order(agv_id, "due", self.homes[agv_id])
                changed = True
        if rule.queue:
            standing = {a: self._nearest(xy, a) for a, xy in positions.items()}
            for agv_id, charger in rule.grant(self.homes, standing, now):
                self.homes[agv_id] = charger
                self._order(agv_id, "charge", charger)
                changed = True
        if changed:
            self._publish(CHARGE_PROPERTY, self.wire())

    def answer(self, vehicle_id: str, value: Any) -> None:
        """``vehicle_id`` published ``value`` as its :data:`CHARGED_PROPERTY`: if that
        answers its ``charge`` order, free the charger and order it to rest."""
        order = self.orders.get(vehicle_id)
        if order is None or order[1] != "charge" or order[0] != value:
            return
        charger = order[2]
        rest = self.rule.charged(vehicle_id, charger, charger) or charger
        self.homes[vehicle_id] = rest
        self._refilled.add(vehicle_id)
        self._order(vehicle_id, "rest", rest)
        self._publish(CHARGE_PROPERTY, self.wire())

    def status(self, vehicle_id: str) -> str | None:
        """``charging``, ``to-charger`` or ``empty`` as the control has it; None: at work."""
        return self.rule.status(vehicle_id)

    def _order(self, vehicle_id: str, kind: str, point: str) -> None:
        self._count += 1
        self.orders[vehicle_id] = (self._count, kind, point)

    def _nearest(self, position: Any, agv_id: str) -> str:
        """The layout point nearest a reported position (its home if malformed)."""
        if not (isinstance(position, Sequence) and len(position) >= 2):
            return self.homes[agv_id]
        x, y = _level(position[0]), _level(position[1])
        if x is None or y is None:
            return self.homes[agv_id]
        layout = self._layout
        return min(
            layout.points, key=lambda p: math.hypot(layout.point(p).x - x, layout.point(p).y - y)
        )
