"""What both fleets answer alike for the dashboard's ``FleetSource`` protocol.

:class:`FleetSourceBase` holds the floor plan, the :class:`~agv_app.tasks.desk.TaskDesk`
and the pause flag, and answers from them; the simulated fleet and the mesh fleet add
what differs (vehicles, nodes, time, metrics, creating tasks).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from typing import Any

from agv_app.fleet.holding import HoldOrders
from agv_app.fleet.view import OBSERVER_ID
from agv_app.layout.graph import Layout
from agv_app.tasks.book import TaskRecord
from agv_app.tasks.desk import TaskDesk
from agv_app.tasks.station import Station
from objectplaces import Initiator

__all__ = ["FleetSourceBase"]


class FleetSourceBase:
    """The floor plan, the task desk and pausing, shared by both fleets.

    Args:
        layout: the floor plan.
        desk: where the fleet's tasks are created and followed.
    """

    def __init__(self, layout: Layout, desk: TaskDesk) -> None:
        self.layout = layout
        self.desk = desk
        self._paused = False
        self.holds = HoldOrders()
        """Which vehicles the operator told to stand (``stop_vehicles``)."""

    def layout_view(self) -> Layout:
        """The floor plan."""
        return self.layout

    @property
    def observer_id(self) -> str:
        """The dashboard's observer node (no position)."""
        return OBSERVER_ID

    def initiator_roles(self) -> Mapping[str, Callable[[Mapping[str, Any]], Initiator]]:
        """None: locks and awards belong to the fleet's own components, not to HTTP users."""
        return {}

    @property
    def stations(self) -> Mapping[str, Station]:
        """The pick stations' task-assignment components, by station id."""
        return self.desk.stations

    def cancel_task(self, task_id: str) -> None:
        """Withdraw a task that no AGV holds yet.

        Raises:
            KeyError: no open task has that id.
            ValueError: an AGV holds it.
        """
        self.desk.cancel(task_id)

    @property
    def open_tasks(self) -> list[str]:
        """Ids of tasks created and not finished, oldest first."""
        return self.desk.book.open_ids()

    def task_records(self) -> list[TaskRecord]:
        """Every task the book holds in detail: the last finished, then the open ones."""
        return self.desk.book.records()

    def task_record(self, task_id: str) -> TaskRecord | None:
        """The task ``task_id`` as the book holds it, or None if it holds it no more."""
        return self.desk.book.get(task_id)

    def pause(self) -> None:
        """Pause: the simulated fleet stops its clock; the mesh fleet, whose AGV
        processes run in real time, stops issuing automatic tasks."""
        self._paused = True

    def resume(self) -> None:
        """Undo ``pause()``."""
        self._paused = False

    @property
    def paused(self) -> bool:
        """True between ``pause()`` and ``resume()``."""
        return self._paused

    @property
    def automatic_tasks(self) -> bool:
        """Whether the fleet creates its automatic tasks now: not while paused, nor
        while a fleet stop is in force (tasks asked for by name are still taken)."""
        return not self._paused and not self.holds.fleet

    def stop_vehicles(self, vehicle_ids: Collection[str] | None = None) -> None:
        """Stop ``vehicle_ids`` (None: the whole fleet): each brakes to a standstill
        within its braking distance and stands, locks kept (:mod:`agv_app.fleet.holding`).

        Raises:
            KeyError: a vehicle is not in the fleet (the message names the known ones).
        """
        self._check_known(vehicle_ids)
        self.holds.stop(vehicle_ids)
        self._apply_holds()

    def resume_vehicles(self, vehicle_ids: Collection[str] | None = None) -> None:
        """Let ``vehicle_ids`` (None: the fleet) drive on; every order goes on.

        Raises:
            KeyError: a vehicle is not in the fleet.
            ValueError: a vehicle is to resume while the whole fleet is stopped.
        """
        self._check_known(vehicle_ids)
        self.holds.resume(vehicle_ids)
        self._apply_holds()

    def set_service(self, vehicle_ids: Collection[str], *, in_service: bool) -> None:
        """Take ``vehicle_ids`` out of service (each hands back a task it has not loaded,
        delivers a loaded one, parks at home and takes no more), or bring them back
        (:mod:`agv_app.vehicle.service`).

        Raises:
            KeyError: a vehicle is not in the fleet.
        """
        self._check_known(vehicle_ids)
        self.holds.set_service(vehicle_ids, in_service=in_service)
        self._apply_holds()

    def send_home(self, vehicle_id: str) -> None:
        """Send ``vehicle_id`` home: it hands back a task it has not loaded, drives to
        its home and takes tasks again once there (:mod:`agv_app.vehicle.service`).

        Raises:
            KeyError: the vehicle is not in the fleet.
            ValueError: it cannot go now: out of service, failed, or loaded.
        """
        self._check_known([vehicle_id])
        if not self.holds.in_service(vehicle_id):
            raise ValueError(f"{vehicle_id} is out of service: it parks at its home already")
        self._send_home(vehicle_id)

    def service_asked(self, vehicle_id: str) -> bool:
        """Whether ``vehicle_id`` is to be in service (what was asked)."""
        return self.holds.in_service(vehicle_id)

    @property
    def fleet_stopped(self) -> bool:
        """True between a fleet stop and a fleet resume (what was asked, not done)."""
        return self.holds.fleet

    def stop_asked(self, vehicle_id: str) -> bool:
        """Whether ``vehicle_id`` was told to stand (the fleet's stop or its own)."""
        return self.holds.held(vehicle_id)

    def vehicle_ids(self) -> Collection[str]:
        """The ids of the fleet's vehicles."""
        raise NotImplementedError

    def _send_home(self, vehicle_id: str) -> object:
        """Tell the known, in-service ``vehicle_id`` to go home (ValueError: it cannot)."""
        raise NotImplementedError

    def _apply_holds(self) -> None:
        """Tell the vehicles what ``holds`` says."""
        raise NotImplementedError

    def _check_known(self, vehicle_ids: Collection[str] | None) -> None:
        if vehicle_ids is None:
            return
        known = set(self.vehicle_ids())
        unknown = sorted(set(vehicle_ids) - known)
        if unknown:
            raise KeyError(f"unknown vehicle {unknown[0]!r} (known: {', '.join(sorted(known))})")
