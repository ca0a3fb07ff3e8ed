"""The task stream the random floors run at: as many tasks as the fleet asks for, over
what the floor carries.

A load makes tasks at a share of the lesser of what the fleet and the floor carry
(:mod:`agv_app.tasks.load`). The random floors stress the traffic rules instead: their
stream is a share of the fleet's rate alone (``load * N / T``), so on a floor bound by
one shared stretch AGVs queue for it, and every seed of the floor runner replays the
floor, fleet and stream it always did.
"""

from __future__ import annotations

from agv_app.fleet import FleetConfig
from agv_app.layout import Layout
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
from agv_app.tasks import (
    FreeFlowTimer,
    drop_stations,
    initial_tasks,
    mean_task_seconds,
    pick_stations,
)
from agv_app.vehicle.kinematics import VehicleSpec

__all__ = ["fleet_demand"]


def fleet_demand(layout: Layout, *, agvs: int, load: float) -> tuple[float, int]:
    """``(task_interval, start_tasks)`` for :class:`FleetConfig`: ``load`` of what
    ``agvs`` AGVs of the default spec carry on ``layout``, the floor aside."""
    speed = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M).max_speed_m_s
    timer = FreeFlowTimer(layout, speed, FleetConfig().dwell)
    mean = mean_task_seconds(timer, pick_stations(layout), drop_stations(layout))
    return mean / (load * agvs), initial_tasks(agvs=agvs, load=load)
