"""Traffic rules: collision avoidance, deadlock avoidance and the safety monitor."""

from __future__ import annotations

from agv_app.traffic.collision import (
    AGV_KIND,
    LockBook,
    LockEntry,
    MessageTally,
    Priority,
    RequestEntry,
    Requester,
    StaleRecord,
    Voter,
    broadcast_group,
    collision_group,
    decide_vote,
    request_coords,
    stale_area,
)
from agv_app.traffic.deadlock import (
    DEFAULT_CLEARANCE_M,
    StopPlan,
    clearance_for,
)
from agv_app.traffic.monitor import (
    SafetyMonitor,
    SafetyViolation,
)

__all__ = [
    "AGV_KIND",
    "DEFAULT_CLEARANCE_M",
    "LockBook",
    "LockEntry",
    "MessageTally",
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
