"""Fleets of AGVs: simulated on one network, or as processes on the WebSocket mesh.

:mod:`agv_app.fleet.agv_process` (one AGV process, run with ``python -m``) is not
imported here: it is a program, started by :mod:`agv_app.fleet.processes`.
"""

from __future__ import annotations

from agv_app.fleet.base import (
    FleetSourceBase,
)
from agv_app.fleet.demo import (
    DEMO_AGVS,
    demo_source,
)
from agv_app.fleet.mesh import (
    MeshFleet,
)
from agv_app.fleet.metrics import (
    FleetMetrics,
)
from agv_app.fleet.observed import (
    LastingOverlaps,
    ObservedAgv,
    vehicle_state,
)
from agv_app.fleet.parking import (
    ParkingPlan,
    home_heading,
    parking_capacity,
    parking_spots,
)
from agv_app.fleet.processes import (
    AgvProcesses,
)
from agv_app.fleet.sim import (
    Fleet,
    FleetConfig,
    SafetyError,
)
from agv_app.fleet.stalls import (
    LONG_WAIT_S,
    STALL_LIMIT_S,
    StallWatch,
)
from agv_app.fleet.view import (
    OBSERVER_ID,
    VehicleState,
    area_rings,
)

__all__ = [
    "DEMO_AGVS",
    "LONG_WAIT_S",
    "OBSERVER_ID",
    "STALL_LIMIT_S",
    "AgvProcesses",
    "Fleet",
    "FleetConfig",
    "FleetMetrics",
    "FleetSourceBase",
    "LastingOverlaps",
    "MeshFleet",
    "ObservedAgv",
    "ParkingPlan",
    "SafetyError",
    "StallWatch",
    "VehicleState",
    "area_rings",
    "demo_source",
    "home_heading",
    "parking_capacity",
    "parking_spots",
    "vehicle_state",
]
