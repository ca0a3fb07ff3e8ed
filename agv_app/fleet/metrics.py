"""Fleet figures: throughput, task times, shares of idle and waiting time, traffic.

Collected by :class:`~agv_app.fleet.Fleet` while it runs (the task figures come from its
:class:`~agv_app.tasks.book.TaskBook`); :meth:`FleetMetrics.summary` turns them into the
flat dictionary that ``objectplaces sim`` prints and writes. Lock waits are
:class:`~agv_app.samples.Samples`: memory stays bounded however long the run.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from agv_app.fleet.stalls import StallWatch
from agv_app.samples import Samples
from agv_app.tasks.book import TaskBook

__all__ = ["FleetMetrics"]


@dataclass(slots=True)
class FleetMetrics:
    """Raw counters of one run (times in simulated seconds)."""

    lock_waits: Samples = field(default_factory=Samples)
    """Seconds each granted lock request waited."""
    agv_seconds: float = 0.0
    idle_seconds: float = 0.0
    waiting_seconds: float = 0.0
    protocol: dict[str, list[int]] = field(default_factory=dict)
    """Role message type -> [messages, bytes of payload]."""
    last_resorts: dict[str, int] = field(default_factory=dict)
    """How often the AGVs backed off (``yield``), drove on (``drive_on``) or took another
    way (``detour``)."""

    def tally(self, kind: str, size: int) -> None:
        """Count one role message of ``kind`` with ``size`` payload bytes."""
        entry = self.protocol.setdefault(kind, [0, 0])
        entry[0] += 1
        entry[1] += size

    def last_resort(self, kind: str) -> None:
        """Count one ``yield``, ``drive_on`` or ``detour`` of an AGV."""
        self.last_resorts[kind] = self.last_resorts.get(kind, 0) + 1

    def summary(
        self,
        *,
        tasks: TaskBook,
        tasks_returned: int,
        tasks_refused: int,
        stalls: StallWatch,
        free_flow_tasks_per_hour: float,
        agvs: int,
        sim_seconds: float,
        wall_seconds: float,
        collisions: int,
        lock_overlaps: int,
        messages: int,
        bytes_: int,
        agv_sent: Mapping[str, tuple[int, int]],
    ) -> dict[str, float]:
        """The figures ``objectplaces sim`` reports (flat, JSON-ready).

        ``messages`` and ``bytes`` count every frame on the network (stations and
        observer included); the ``*_per_agv_per_s`` figures count what the AGVs' nodes
        sent (``agv_sent``: wire kind -> (frames, bytes)), per AGV and simulated second.
        Means and maxima cover the whole run; percentiles the most recent values.
        ``free_flow_tasks_per_hour`` is the bound of
        :class:`~agv_app.tasks.free_flow.FreeFlowBound`; ``stalls_60s`` counts the waits
        longer than 60 s and ``max_wait`` is the longest single wait (``stalls``);
        ``tasks_refused`` counts the tasks the desk refused while it held its limit of
        open ones (``BACKLOG_LIMIT``); ``yields``, ``drive_ons`` and ``detours`` count
        the AGVs' last resorts against a circle of waits (docs/traffic.md).
        """
        per = max(agvs, 1) * max(sim_seconds, 1e-9)
        done, times, waits = tasks.counts["done"], tasks.durations, self.lock_waits
        out: dict[str, float] = {
            "agvs": agvs,
            "sim_seconds": round(sim_seconds, 3),
            "wall_seconds": round(wall_seconds, 3),
            "sim_speed": round(sim_seconds / wall_seconds, 2) if wall_seconds > 0 else 0.0,
            "tasks_created": tasks.counts["created"],
            "tasks_completed": done,
            "tasks_returned": tasks_returned,
            "tasks_refused": tasks_refused,
            "tasks_per_hour": round(done * 3600 / max(sim_seconds, 1e-9), 2),
            "free_flow_tasks_per_hour": round(free_flow_tasks_per_hour, 2),
            "task_time_mean": round(times.mean, 2),
            "task_time_p95": round(times.percentile(95), 2),
            "idle_share": round(self.idle_seconds / self.agv_seconds, 4)
            if self.agv_seconds
            else 0.0,
            "waiting_share": round(self.waiting_seconds / self.agv_seconds, 4)
            if self.agv_seconds
            else 0.0,
            "lock_wait_mean": round(waits.mean, 3),
            "lock_wait_p95": round(waits.percentile(95), 3),
            "lock_wait_max": round(waits.maximum, 3),
            "locks_granted": waits.count,
            "messages": messages,
            "bytes": bytes_,
            "messages_per_agv_per_s": round(sum(v[0] for v in agv_sent.values()) / per, 3),
            "bytes_per_agv_per_s": round(sum(v[1] for v in agv_sent.values()) / per, 2),
            "collisions": collisions,
            "lock_overlaps": lock_overlaps,
            "deadlocks": stalls.deadlocks,
            "stalls_60s": stalls.long_waits,
            "max_wait": round(stalls.max_wait, 2),
            "double_assignments": tasks.double_assignments,
            "yields": self.last_resorts.get("yield", 0),
            "drive_ons": self.last_resorts.get("drive_on", 0),
            "detours": self.last_resorts.get("detour", 0),
        }
        for kind, (n, b) in sorted(agv_sent.items()):
            out[f"wire_{kind}_messages_per_agv_per_s"] = round(n / per, 3)
            out[f"wire_{kind}_bytes_per_agv_per_s"] = round(b / per, 2)
        for kind, (n, b) in sorted(self.protocol.items()):
            out[f"role_{kind}_messages_per_agv_per_s"] = round(n / per, 4)
            out[f"role_{kind}_payload_bytes_per_agv_per_s"] = round(b / per, 2)
        return out
