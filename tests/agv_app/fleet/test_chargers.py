"""Batteries in the simulated fleet: an AGV low on charge finishes its order, drives to
a free charger, charges and returns to service; one that runs empty stops and raises an
alarm. Virtual time."""

from __future__ import annotations

from pathlib import Path

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.chargers import charger_points
from agv_app.fleet.parking import ParkingPlan
from agv_app.geometry import Pose
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.vehicle import SimDriver
from agv_app.vehicle.battery import BatterySpec
from agv_app.vehicle.kinematics import VehicleSpec
from agv_app.vehicle.state_file import StateFile

FAST_DRAIN = BatterySpec(
    drain_per_m=0.1,
    drain_per_load_s=0.05,
    drain_idle_per_s=0.002,
    charge_per_s=0.5,
    charge_below=30.0,
    charge_to=90.0,
)


def _fleet(agvs: int = 6, **kw: object) -> Fleet:
    cfg = FleetConfig(agvs=agvs, seed=3, fail_on_violation=True, load=0.7, **kw)  # type: ignore[arg-type]
    return Fleet(demo_warehouse(), cfg)


def test_without_batteries_nothing_changes() -> None:
    fleet = _fleet()
    assert fleet.chargers is None
    assert all(agv.battery is None for agv in fleet.agvs.values())
    fleet.run(5.0)
    assert "charges" not in fleet.summary()
    assert all(v.status != "charging" for v in fleet.vehicles())


def test_chargers_are_no_rest_points_when_batteries_are_on() -> None:
    layout = demo_warehouse()
    chargers = charger_points(layout)
    assert len(chargers) == 10
    plan = ParkingPlan(layout, VehicleSpec(), 20)
    plan.set_aside(chargers)
    for k in range(40):
        plan.claim(f"x{k}", plan.homes[k % 20])
    rest = plan.relocate("agv-01", plan.homes[0], plan.homes[0])
    assert rest is not None
    assert rest not in chargers
    got = plan.relocate("agv-02", plan.homes[1], plan.homes[1], among=chargers)
    assert got in chargers
    assert plan.owner(got) == "agv-02"
    # No two at one charger: the one claimed is not handed out again.
    other = plan.relocate("agv-03", plan.homes[2], got, among=chargers)
    assert other != got


def test_a_low_battery_sends_the_agv_to_a_charger_and_back_to_work() -> None:
    fleet = _fleet(batteries=FAST_DRAIN)
    chargers = fleet.chargers
    assert chargers is not None
    seen = set()
    for _ in range(round(900.0 / fleet.config.dt)):
        fleet.step()
        for v in fleet.vehicles():
            seen.add(v.status)
            if v.status == "charging":
                agv = fleet.agvs[v.id]
                assert agv.point in chargers.points
                assert not agv.in_service  # it bids for nothing while it charges
    assert {"to-charger", "charging"} <= seen
    stats = chargers.stats
    assert stats.charges >= 2
    done = [s for s in stats.sessions if s[3] != float("inf")]
    assert done, "no charge ended"
    agv_id = done[0][1]
    assert chargers.takes_tasks(agv_id) or chargers.status(agv_id) is not None
    assert stats.ran_empty == 0
    summary = fleet.summary()
    assert summary["charges"] == stats.charges
    assert summary["min_state_of_charge"] > 0


def test_an_agv_that_runs_empty_stops_and_raises_an_alarm() -> None:
    fleet = _fleet(batteries=FAST_DRAIN)
    chargers = fleet.chargers
    assert chargers is not None
    fleet.run(60.0)
    moving = max(fleet.agvs.values(), key=lambda a: a.vehicle.speed)
    assert moving.vehicle.speed > 0
    chargers.batteries[moving.node_id].drain(idle_s=1e9)
    fleet.run(30.0)
    assert chargers.empty(moving.node_id)
    assert moving.held
    assert moving.vehicle.speed == 0.0
    assert [a for _, a, _ in chargers.alarms] == [moving.node_id]
    shown = {v.id: v.status for v in fleet.vehicles()}
    assert shown[moving.node_id] == "empty"
    assert fleet.summary()["ran_empty"] == 1
    assert not moving.in_service


def test_a_rebooted_agv_keeps_its_battery(tmp_path: Path) -> None:
    spec = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)

    def drivers(agv_id: str, pose: Pose) -> SimDriver:
        return SimDriver.recovered(spec, StateFile(tmp_path / f"{agv_id}.json"), default=pose)

    cfg = FleetConfig(agvs=2, seed=3, task_until=0.0, batteries=FAST_DRAIN)
    fleet = Fleet(demo_warehouse(), cfg, spec=spec, drivers=drivers)
    chargers = fleet.chargers
    assert chargers is not None
    battery = chargers.batteries["agv-01"]
    battery.drain(metres=300.0)
    fleet.crash("agv-01")
    fleet.run(5.0)
    agv = fleet.reboot("agv-01")
    assert agv.battery is battery
    assert battery.state_of_charge(fleet.now) < 71.0
