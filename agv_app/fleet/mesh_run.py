"""Starting a mesh fleet and stopping it again: the nodes in its own process
(:class:`~agv_app.fleet.mesh_nodes.LocalNodes`), the AGV processes it spawns
(:class:`~agv_app.fleet.processes.AgvProcesses`), and the tasks that check the observed
AGVs a few times a second and monitor the VDA 5050 broker.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable

from agv_app.fleet.mesh_nodes import LocalNodes
from agv_app.fleet.mesh_options import AgvLaunch, Joining
from agv_app.fleet.processes import AgvProcesses
from agv_app.tasks.desk import TaskDesk
from agv_app.vda5050.monitor import BrokerMonitor

__all__ = ["MeshRun"]

_CHECK_INTERVAL_S = 0.25


class MeshRun:
    """What a mesh fleet starts, and stops again.

    Args:
        nodes: the observer, the base, the PKI and the router in this process (its
            :class:`~agv_app.fleet.mesh_nodes.LocalNodes`).
        processes: the AGV processes.
        desk: the task desk, opened on the base once it runs.
        launch: how the AGV processes run and link.
        agv_ids: the AGVs to spawn, in order.
        homes: each one's parking spot.
        joining: join a fleet that runs elsewhere instead (spawn nothing).
        check: called a few times a second while the fleet runs.
        broker_monitor: run alongside (with a VDA 5050 broker).
        stop_timeout: how long ``stop`` waits for the processes after SIGTERM.
    """

    def __init__(
        self,
        nodes: LocalNodes,
        processes: AgvProcesses,
        desk: TaskDesk,
        launch: AgvLaunch,
        *,
        agv_ids: list[str],
        homes: list[str],
        joining: Joining | None,
        check: Callable[[], None],
        broker_monitor: BrokerMonitor | None,
        stop_timeout: float,
    ) -> None:
        self.nodes = nodes
        self.processes = processes
        self.desk = desk
        self.launch = launch
        self.agv_ids = agv_ids
        self.homes = homes
        self.joining = joining
        self.check = check
        self.broker_monitor = broker_monitor
        self.stop_timeout = stop_timeout
        self.stopped = False
        self.final_logs: dict[str, str] = {}
        """Every AGV process's output once ``stop`` has reaped them (its last line,
        ``closed``, tells how late its control steps ran)."""
        self._watcher: asyncio.Task[None] | None = None
        self._monitor_task: asyncio.Task[None] | None = None

    async def start(self, loop: asyncio.AbstractEventLoop) -> None:
        """Start the nodes (joining a fleet, or for AGV processes) and spawn the AGV
        processes; the checks and the broker monitor run from then on."""
        node_args = self.launch.node_arguments()
        zenoh = self.launch.transport == "zenoh"
        if self.joining is not None:
            self.desk.open_base(await self.nodes.join(self.joining, node_args, zenoh))
            self._watcher = loop.create_task(self._watch(), name="mesh-fleet-watch")
            return
        self.processes.open_run_dir()
        link_args = await self.nodes.start(self.agv_ids, node_args, self.launch)
        pki, base = self.nodes.pki, self.nodes.base
        assert pki is not None
        assert base is not None
        self.desk.open_base(base)
        peers = len(self.agv_ids) + 1  # the observer, the base and the other AGVs
        for i, (agv_id, home) in enumerate(zip(self.agv_ids, self.homes, strict=True)):
            self.processes.spawn(
                agv_id, self.launch.arguments(i, home, link_args, pki.directory, peers)
            )
        self._watcher = loop.create_task(self._watch(), name="mesh-fleet-watch")
        if self.broker_monitor is not None:
            self._monitor_task = loop.create_task(self.broker_monitor.run(), name="vda5050-monitor")

    async def _watch(self) -> None:
        """Check the observed shapes and stalls a few times a second, until cancelled."""
        while True:
            await asyncio.sleep(_CHECK_INTERVAL_S)
            self.check()

    async def stop(self) -> None:
        """Stop everything: terminate and reap every AGV process, close the nodes.
        Idempotent."""
        if self.stopped:
            return
        self.stopped = True
        for task in (self._watcher, self._monitor_task):
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        self._watcher = self._monitor_task = None
        await self.processes.reap(self.stop_timeout)
        await self.nodes.close()
        self.final_logs = self.processes.logs()
        self.processes.close()
        self.nodes.remove_pki()
