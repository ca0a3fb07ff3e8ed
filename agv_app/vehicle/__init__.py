"""One AGV: its vehicle behind a driver, the kinematics of the simulated one, and the
component that drives it."""

from __future__ import annotations

from agv_app.vehicle.controller import (
    AgvConfig,
    AgvController,
)
from agv_app.vehicle.driven import (
    DrivenVehicle,
    planning_spec,
)
from agv_app.vehicle.driver import (
    DriverEvent,
    DriverFault,
    DriverLimits,
    PoseReport,
    PoseReported,
    Stopped,
    VehicleDriver,
)
from agv_app.vehicle.kinematics import (
    Vehicle,
    VehicleSpec,
)
from agv_app.vehicle.sim_driver import (
    SimDriver,
)

__all__ = [
    "AgvConfig",
    "AgvController",
    "DrivenVehicle",
    "DriverEvent",
    "DriverFault",
    "DriverLimits",
    "PoseReport",
    "PoseReported",
    "SimDriver",
    "Stopped",
    "Vehicle",
    "VehicleDriver",
    "VehicleSpec",
    "planning_spec",
]
