"""A mesh fleet's observed figures: tasks, the traffic of the links of the nodes in the
fleet's own process, safety and stalls (:meth:`~agv_app.fleet.mesh.MeshFleet.metrics`).
"""

from __future__ import annotations

from collections.abc import Mapping

from agv_app.fleet.processes import AgvProcesses
from agv_app.fleet.roster import AgvRoster
from agv_app.fleet.stalls import StallWatch
from agv_app.tasks.desk import TaskDesk
from agv_app.tasks.free_flow import FreeFlowBound
from agv_app.traffic.monitor import SafetyMonitor
from agv_app.vda5050.monitor import BrokerMonitor
from objectplaces.mesh import MeshNode

__all__ = ["link_traffic", "mesh_figures"]


def link_traffic(local: list[MeshNode], transport: str) -> tuple[int, int]:
    """Frames and bytes on the links of the nodes in this process, each frame once
    (on Zenoh, which keeps no per-link counters: what these nodes put and heard)."""
    by_id = {n.node_id: n for n in local}
    messages = bytes_ = 0
    for node in by_id.values():
        if transport == "zenoh":
            counters = node.transport_counters()
            messages += counters.get("frames_out", 0) + counters.get("frames_in", 0)
            bytes_ += counters.get("bytes_out", 0) + counters.get("bytes_in", 0)
            continue
        for peer, stats in node.peer_stats().items():
            messages += stats.messages_out
            bytes_ += stats.bytes_out
            if peer not in by_id:
                messages += stats.messages_in
                bytes_ += stats.bytes_in
    return messages, bytes_


def mesh_figures(
    desk: TaskDesk,
    roster: AgvRoster,
    processes: AgvProcesses,
    *,
    traffic: tuple[int, int],
    fleet_size: int,
    agvs_seen: int,
    free_flow: FreeFlowBound,
    monitor: SafetyMonitor,
    stalls: StallWatch,
    broker_monitor: BrokerMonitor | None,
    now: float,
) -> Mapping[str, float]:
    """The observed figures (``traffic``: :func:`link_traffic`; ``fleet_size``: the AGVs
    spawned or, joining a fleet, heard so far; ``agvs_seen``: those the observer hears)."""
    book = desk.book
    done = book.counts["done"]
    messages, bytes_ = traffic
    failed = roster.failed()
    hours = now / 3600.0
    return {
        "agvs": float(fleet_size - len(failed) - len(roster.left())),
        "agvs_failed": float(len(failed)),
        "agvs_seen": float(agvs_seen),
        "processes_running": float(processes.running()),
        "tasks_created": float(book.counts["created"]),
        "tasks_completed": float(done),
        "tasks_open": float(len(book.open_ids())),
        "tasks_returned": float(desk.returned),
        "tasks_refused": float(desk.refused),
        "tasks_per_hour": done / hours if hours > 0 else 0.0,
        "free_flow_tasks_per_hour": free_flow.per_hour(now),
        "task_time_mean_s": book.durations.mean,
        "messages": float(messages),
        "bytes": float(bytes_),
        "collisions": float(monitor.collisions),
        "lock_overlaps": float(monitor.lock_overlaps),
        "deadlocks": float(stalls.deadlocks),
        "stalls_60s": float(stalls.long_waits),
        "max_wait": stalls.max_wait,
        **({} if broker_monitor is None else broker_monitor.status()),
    }
