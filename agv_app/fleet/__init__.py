"""Fleets of AGVs: simulated on one network, or as processes on the WebSocket mesh."""

from __future__ import annotations

from agv_app.fleet.mesh import (
    OBSERVER_ID,
    MeshFleet,
    parking_points,
)
from agv_app.fleet.metrics import (
    FleetMetrics,
    percentile,
)
from agv_app.fleet.sim import (
    Fleet,
    FleetConfig,
    VehicleState,
    demo_source,
    parking_capacity,
)

__all__ = [
    "OBSERVER_ID",
    "Fleet",
    "FleetConfig",
    "FleetMetrics",
    "MeshFleet",
    "VehicleState",
    "demo_source",
    "parking_capacity",
    "parking_points",
    "percentile",
]
