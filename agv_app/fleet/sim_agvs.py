"""A simulated fleet's AGV components, each on a node of its own: built, crashed,
brought back on a fresh node, or restarted as a fresh component (a rebooted process).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any

from agv_app.fleet.sim_build import pose_at, take_over
from agv_app.geometry import Area, Pose
from agv_app.layout.graph import Layout
from agv_app.traffic.stale_relay import StaleListener
from agv_app.vehicle.controller import AgvController
from agv_app.vehicle.driver import VehicleDriver
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces import RoleActivator
from objectplaces.sim import SimulatedNetwork

__all__ = ["AgvNodes", "DriverFactory"]

DriverFactory = Callable[[str, Pose], VehicleDriver]
"""Builds an AGV's driver: ``(agv id, where it stands at first)``; asked again when the
AGV's process restarts (:meth:`AgvNodes.reboot`), when a driver that keeps its pose
(``SimDriver.recovered``) finds it where it stood."""


class AgvNodes:
    """The AGV components of a simulated fleet and their nodes.

    Args:
        net: the network their nodes join.
        layout: the floor plan.
        spec: the vehicles' size and limits.
        vehicle: builds each AGV component, with the arguments of
            :class:`~agv_app.vehicle.controller.AgvController`.
        interest_radius: the AGV nodes' interest radius (None: they hear every node).
        footprint_margin: the AGV nodes' footprint margin.
        drivers: builds each AGV's driver when it reboots (None: it cannot).
        on_task_started: told ``(agv id, task id)`` when an AGV sets off with a task.
        options: the other keyword arguments of every component (hooks, config).
    """

    def __init__(
        self,
        net: SimulatedNetwork,
        layout: Layout,
        spec: VehicleSpec,
        vehicle: Callable[..., AgvController],
        *,
        interest_radius: float | None,
        footprint_margin: float | None,
        drivers: DriverFactory | None,
        on_task_started: Callable[[str, str], None],
        options: Mapping[str, Any],
    ) -> None:
        self.net = net
        self.layout = layout
        self.spec = spec
        self.vehicle = vehicle
        self.interest_radius = interest_radius
        self.footprint_margin = footprint_margin
        self.drivers = drivers
        self.on_task_started = on_task_started
        self.options = options
        self.agvs: dict[str, AgvController] = {}
        """Every AGV component, by id."""
        self.truths: dict[str, Callable[[], Area]] = {}
        """The hull each AGV truly has, where its driver says (``true_hull()``)."""
        self.left: set[str] = set()
        """AGVs whose driver failed and whose node said goodbye."""

    def build(
        self, agv_id: str, home: str, start: str, pose: Pose, driver: VehicleDriver | None
    ) -> AgvController:
        """An AGV component on a new node (with ``driver``, standing where it says)."""
        node = self.net.add_node(
            agv_id, interest_radius=self.interest_radius, footprint_margin=self.footprint_margin
        )
        extra: dict[str, VehicleDriver] = {} if driver is None else {"driver": driver}
        agv = self.vehicle(
            node,
            self.layout,
            self.spec,
            home,
            start=start,
            heading_rad=pose.heading_rad,
            on_task_started=functools.partial(self.on_task_started, agv_id),
            **self.options,
            **extra,
        )
        truth = getattr(driver, "true_hull", None)
        self.truths.pop(agv_id, None)
        if callable(truth):
            self.truths[agv_id] = truth
        self.agvs[agv_id] = agv
        self._listen(agv_id, node)
        return agv

    def crash(self, agv_id: str) -> None:
        """Crash an AGV's node: it stops where it stands, its hull stays on the floor."""
        self.net.remove_node(agv_id)
        self.agvs[agv_id].fail()

    def recover(self, agv_id: str) -> None:
        """Bring a crashed AGV back on a fresh node."""
        node = self.net.add_node(
            agv_id, interest_radius=self.interest_radius, footprint_margin=self.footprint_margin
        )
        self.left.discard(agv_id)
        self.agvs[agv_id].restart(node)
        self._listen(agv_id, node)

    def reboot(self, agv_id: str) -> AgvController:
        """A new component for a crashed AGV on a fresh node, its vehicle where the
        driver (asked anew) says it stands, the task it held handed back.

        Raises:
            ValueError: there are no ``drivers``, or the AGV has not crashed.
        """
        old = self.agvs[agv_id]
        if self.drivers is None or not old.failed:
            raise ValueError(f"{agv_id} cannot reboot: no drivers, or it has not crashed")
        self.left.discard(agv_id)
        home = old.home
        driver = self.drivers(agv_id, pose_at(self.layout, home, None))
        agv = self.build(agv_id, home, home, pose_at(self.layout, home, None), driver)
        take_over(old, agv)
        return agv

    def _listen(self, agv_id: str, node: RoleActivator) -> None:
        """A scoped AGV takes the failed AGVs the observer relays into its lock book."""
        if self.interest_radius is not None:
            agv = self.agvs[agv_id]
            StaleListener(node, lambda: agv.book)
