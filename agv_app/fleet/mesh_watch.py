"""What a mesh fleet knows of its AGVs from its observer: who is heard, what each shows
(its display session, :mod:`agv_app.fleet.display_feed`), who failed
(:class:`~agv_app.fleet.roster.AgvRoster`), the tasks it sees start and end, and the
safety and stall checks over what it hears.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Mapping
from typing import Any

from agv_app.fleet.display_feed import DisplayCollector
from agv_app.fleet.mesh_charging import MeshCharging
from agv_app.fleet.mesh_figures import mesh_figures
from agv_app.fleet.mesh_views import agv_ids_heard, agv_view, agv_views, reported_route
from agv_app.fleet.observed import LastingOverlaps
from agv_app.fleet.processes import AgvProcesses
from agv_app.fleet.remote import RemoteNode
from agv_app.fleet.roster import AgvRoster
from agv_app.fleet.stalls import StallWatch
from agv_app.fleet.view import VehicleState
from agv_app.geometry import XY
from agv_app.tasks.desk import TaskDesk
from agv_app.tasks.free_flow import FreeFlowBound
from agv_app.traffic.monitor import SafetyMonitor
from agv_app.vda5050.monitor import BrokerMonitor
from objectplaces.mesh import MeshNode

__all__ = ["ObservedAgvs"]


class ObservedAgvs:
    """A mesh fleet's AGVs as its observer hears them.

    Args:
        agv_ids: the AGVs spawned (empty when joining a fleet: learned as heard).
        desk: the fleet's task desk, told of the tasks the AGVs start and deliver.
        processes: the AGV processes (one that exited marks its AGV failed).
        observer: the observer node (None before the fleet starts).
        clock: the fleet's time, seconds.
        running: whether the fleet runs (failures count only then).
        clock_offset: the monotonic time the fleet's clock starts at (``AgvRoster``).
        min_overlap_s: how long an overlap of observed shapes lasts before it counts.
    """

    def __init__(
        self,
        agv_ids: list[str],
        desk: TaskDesk,
        processes: AgvProcesses,
        *,
        observer: Callable[[], MeshNode | None],
        clock: Callable[[], float],
        running: Callable[[], bool],
        clock_offset: Callable[[], float],
        min_overlap_s: float,
    ) -> None:
        self.agv_ids = agv_ids
        self.desk = desk
        self.processes = processes
        self.observer = observer
        self.clock = clock
        self.running = running
        self.monitor = SafetyMonitor()
        self.overlaps = LastingOverlaps(self.monitor, min_s=min_overlap_s)
        self.stalls = StallWatch(on_long_wait=lambda _agv, now: desk.long_wait(now))
        self.display = DisplayCollector(on_report=self.on_report)
        """What each AGV process shows, reported to the observer (its display session)."""
        self.roster = AgvRoster(
            agv_ids,
            self.views,
            self.view,
            clock_offset=clock_offset,
        )

    def view(self, agv_id: str) -> Mapping[str, Any] | None:
        """One AGV, its display over its properties (None: not heard)."""
        return agv_view(self.observer(), self.display, agv_id)

    def on_property(self, node_id: str, name: str, value: Any) -> None:
        """An AGV's ``last_done``: its task is delivered."""
        if name == "last_done" and isinstance(value, str):
            self.desk.finish(value, now=self.clock())

    def on_report(self, node_id: str, report: Mapping[str, Any]) -> None:
        """An AGV's display report: one that drives with a task has started it."""
        if report.get("state") == "driving":
            task = self.display.reports.get(node_id, {}).get("task")
            if isinstance(task, str):
                self.desk.book.start(task, node_id, now=self.clock())

    def departed(self, node_id: str) -> None:
        """A node departed: an AGV's counts as failed while the fleet runs."""
        if self.running():
            self.roster.departed(node_id)

    def heard(self) -> set[str]:
        """Ids of the AGVs the observer hears."""
        return agv_ids_heard(self.observer())

    def views(self) -> list[tuple[str, Mapping[str, Any]]]:
        """Every AGV the observer hears, by id, its display over its properties."""
        return agv_views(self.observer(), self.display)

    async def wait_ready(self) -> None:
        """Wait until :meth:`missing` names nobody.

        Raises:
            RuntimeError: an AGV process has exited.
        """
        while self.missing():
            dead = self.processes.exited()
            if dead:
                raise RuntimeError(f"AGV processes exited: {', '.join(dead)}")
            await asyncio.sleep(0.1)

    def missing(self) -> list[str]:
        """Ids of the AGVs spawned that the observer has not heard yet, or whose display
        has not come yet."""
        seen, shown = self.heard(), self.display.reports
        return [a for a in self.agv_ids if a not in seen or a not in shown]

    def note_exits(self) -> None:
        """Mark the AGVs whose process exited as failed (while the fleet runs)."""
        if self.running():
            self.roster.exited(self.processes.exit_codes())

    def vehicles(self) -> list[VehicleState]:
        """Every AGV heard, as last heard; a failed one where it was last heard."""
        self.note_exits()
        return self.roster.vehicles()

    def vehicle_ids(self) -> list[str]:
        """The AGVs spawned, or, joining a fleet, every AGV heard so far."""
        self.note_exits()
        return [*self.roster.agv_ids]

    def remote_nodes(self) -> Mapping[str, RemoteNode]:
        """A read-only stand-in for every live AGV node the observer hears."""
        self.note_exits()
        return self.roster.nodes()

    def route(self, vehicle_id: str) -> tuple[XY, ...]:
        """The rest of an AGV's route as it last published it, from where it stands.

        Raises:
            KeyError: no AGV has that id.
        """
        vehicle = next((v for v in self.vehicles() if v.id == vehicle_id), None)
        if vehicle is None:
            raise KeyError(vehicle_id)
        return reported_route(vehicle, agv_view(self.observer(), self.display, vehicle_id) or {})

    def figures(
        self,
        traffic: tuple[int, int],
        *,
        joining: bool,
        agvs: int,
        free_flow: FreeFlowBound,
        broker_monitor: BrokerMonitor | None,
        now: float,
    ) -> Mapping[str, float]:
        """The observed figures (:func:`~agv_app.fleet.mesh_figures.mesh_figures`) with
        ``traffic``; the fleet's size is ``agvs``, or, ``joining``, the AGVs heard so far."""
        self.note_exits()
        return mesh_figures(
            self.desk,
            self.roster,
            self.processes,
            traffic=traffic,
            fleet_size=len(self.roster.agv_ids) if joining else agvs,
            agvs_seen=len(self.heard()),
            free_flow=free_flow,
            monitor=self.monitor,
            stalls=self.stalls,
            broker_monitor=broker_monitor,
            now=now,
        )

    def check(self, now: float, charging: MeshCharging | None = None) -> None:
        """Run the safety monitor over the observed hulls and locks; track stalls; tell
        ``charging`` what the AGVs report.

        An overlap counts once it has lasted ``min_overlap_s``: the observer hears each
        AGV at a different moment, so a short overlap of two views may be two moments.
        """
        vehicles = self.vehicles()
        self.overlaps.check(now, vehicles, self.roster.observed())
        for v in vehicles:
            self.stalls.observe(v.id, stalled=v.status == "waiting", now=now)
        if charging is not None:
            charging.tick(self.views(), now)
