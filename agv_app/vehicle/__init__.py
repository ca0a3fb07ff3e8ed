"""One AGV: kinematics of the vehicle and the component that drives it."""

from __future__ import annotations

from agv_app.vehicle.controller import (
    AgvConfig,
    AgvController,
)
from agv_app.vehicle.kinematics import (
    Vehicle,
    VehicleSpec,
)

__all__ = [
    "AgvConfig",
    "AgvController",
    "Vehicle",
    "VehicleSpec",
]
