"""Fleet figures: throughput, task times, shares of idle and waiting time, traffic.

Collected by :class:`~agv_app.fleet.Fleet` while it runs; :meth:`FleetMetrics.summary`
turns them into the flat dictionary that ``objectplaces sim`` prints and writes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = ["FleetMetrics", "percentile"]


def percentile(values: list[float], q: float) -> float:
    """The ``q``-th percentile (0..100) by linear interpolation; 0 for no values."""
    if not values:
        return 0.0
    xs = sorted(values)
    k = (len(xs) - 1) * q / 100
    lo, hi = math.floor(k), math.ceil(k)
    return xs[lo] + (xs[hi] - xs[lo]) * (k - lo)


@dataclass(slots=True)
class FleetMetrics:
    """Raw counters of one run (times in simulated seconds)."""

    tasks_created: int = 0
    tasks_completed: int = 0
    tasks_returned: int = 0
    double_assignments: int = 0
    task_times: list[float] = field(default_factory=list)
    lock_waits: list[float] = field(default_factory=list)
    agv_seconds: float = 0.0
    idle_seconds: float = 0.0
    waiting_seconds: float = 0.0
    deadlocks: int = 0
    protocol: dict[str, list[int]] = field(default_factory=dict)
    """Role message type -> [messages, bytes of payload]."""

    def tally(self, kind: str, size: int) -> None:
        """Count one role message of ``kind`` with ``size`` payload bytes."""
        entry = self.protocol.setdefault(kind, [0, 0])
        entry[0] += 1
        entry[1] += size

    def summary(
        self,
        *,
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
        """
        per = max(agvs, 1) * max(sim_seconds, 1e-9)
        out: dict[str, float] = {
            "agvs": agvs,
            "sim_seconds": round(sim_seconds, 3),
            "wall_seconds": round(wall_seconds, 3),
            "sim_speed": round(sim_seconds / wall_seconds, 2) if wall_seconds > 0 else 0.0,
            "tasks_created": self.tasks_created,
            "tasks_completed": self.tasks_completed,
            "tasks_returned": self.tasks_returned,
            "tasks_per_hour": round(self.tasks_completed * 3600 / max(sim_seconds, 1e-9), 2),
            "task_time_mean": round(sum(self.task_times) / len(self.task_times), 2)
            if self.task_times
            else 0.0,
            "task_time_p95": round(percentile(self.task_times, 95), 2),
            "idle_share": round(self.idle_seconds / self.agv_seconds, 4)
            if self.agv_seconds
            else 0.0,
            "waiting_share": round(self.waiting_seconds / self.agv_seconds, 4)
            if self.agv_seconds
            else 0.0,
            "lock_wait_mean": round(sum(self.lock_waits) / len(self.lock_waits), 3)
            if self.lock_waits
            else 0.0,
            "lock_wait_p95": round(percentile(self.lock_waits, 95), 3),
            "lock_wait_max": round(max(self.lock_waits, default=0.0), 3),
            "locks_granted": len(self.lock_waits),
            "messages": messages,
            "bytes": bytes_,
            "messages_per_agv_per_s": round(sum(v[0] for v in agv_sent.values()) / per, 3),
            "bytes_per_agv_per_s": round(sum(v[1] for v in agv_sent.values()) / per, 2),
            "collisions": collisions,
            "lock_overlaps": lock_overlaps,
            "deadlocks": self.deadlocks,
            "double_assignments": self.double_assignments,
        }
        for kind, (n, b) in sorted(agv_sent.items()):
            out[f"wire_{kind}_messages_per_agv_per_s"] = round(n / per, 3)
            out[f"wire_{kind}_bytes_per_agv_per_s"] = round(b / per, 2)
        for kind, (n, b) in sorted(self.protocol.items()):
            out[f"role_{kind}_messages_per_agv_per_s"] = round(n / per, 4)
            out[f"role_{kind}_payload_bytes_per_agv_per_s"] = round(b / per, 2)
        return out
