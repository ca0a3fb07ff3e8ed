"""Traffic rules: collision avoidance (the lock book and the requester and voter roles),
deadlock avoidance and the safety monitor.
"""

from __future__ import annotations

from agv_app.traffic.collision import (
    Requester,
    Voter,
    broadcast_group,
    collision_group,
    decide_vote,
    request_coords,
)
from agv_app.traffic.deadlock import (
    DEFAULT_CLEARANCE_M,
    StopPlan,
    clearance_for,
)
from agv_app.traffic.lockbook import (
    LockBook,
    LockEntry,
    Priority,
    RequestEntry,
    StaleRecord,
    stale_area,
)
from agv_app.traffic.monitor import (
    SafetyMonitor,
    SafetyViolation,
)

__all__ = [
    "DEFAULT_CLEARANCE_M",
    "LockBook",
    "LockEntry",
    "Priority",
    "RequestEntry",
    "Requester",
    "SafetyMonitor",
    "SafetyViolation",
    "StaleRecord",
    "StopPlan",
    "Voter",
    "broadcast_group",
    "clearance_for",
    "collision_group",
    "decide_vote",
    "request_coords",
    "stale_area",
]
