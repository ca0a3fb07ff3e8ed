"""An AGV running on its own drains its battery as the simulated fleet's chargers do:
by the metres it drives, the seconds it handles loads, and every second. Virtual time."""

from __future__ import annotations

import math

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.observed import ObservedAgv, vehicle_state
from agv_app.layout.demo import demo_warehouse
from agv_app.vehicle.battery import BatterySpec, SimBattery
from agv_app.vehicle.battery_drain import BatteryDrain


def test_the_battery_drains_by_distance_loads_and_time() -> None:
    fleet = Fleet(demo_warehouse(), FleetConfig(agvs=2, seed=3, task_interval=10.0))
    spec = BatterySpec()
    agv = fleet.agvs["agv-01"]
    agv.battery = battery = SimBattery(spec)
    drain = BatteryDrain(agv)
    assert BatteryDrain(fleet.agvs["agv-02"]).step(0.1) is None, "no battery, nothing drained"
    dt, metres, loading_s = fleet.config.dt, 0.0, 0.0
    last = agv.vehicle.pose()
    steps = round(300.0 / dt)
    for _ in range(steps):
        fleet.step()
        drain.step(dt)
        pose = agv.vehicle.pose()
        metres += math.hypot(pose.x - last.x, pose.y - last.y)
        last = pose
        loading_s += dt if agv.display_status() == "loading" else 0.0
    assert metres > 10.0, "it drove"
    used = metres * spec.drain_per_m + loading_s * spec.drain_per_load_s
    used += (steps - 1) * dt * spec.drain_idle_per_s  # the first step sets where it stood
    assert battery.level == pytest.approx(100.0 - used, abs=0.05)


def test_a_reported_state_of_charge_is_shown_and_a_wrong_one_is_not() -> None:
    props = {"position": (1.0, 2.0), "heading": 0.0, "battery": 87.5}
    assert vehicle_state("agv-01", props, ObservedAgv()).battery == 87.5
    for wrong in (None, "full", 140.0, True):
        shown = vehicle_state("agv-01", {**props, "battery": wrong}, ObservedAgv())
        assert shown.battery is None
